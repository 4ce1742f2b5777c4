// TomlReader: typed reads with defaults, and the first problem kept with file, line and key.
#include "config/toml_reader.h"

#include <gtest/gtest.h>

#include <string>

namespace gaugeloop {
namespace {

// A parsed document that outlives the readers made on it.
class TomlReaderTest : public ::testing::Test {
 protected:
  const toml::table& parse(const std::string& text) {
    Result<toml::table> parsed = parse_toml(text, "t.toml");
    EXPECT_TRUE(parsed.ok()) << parsed.error().message;
    if (parsed.ok()) table_ = std::move(*parsed);
    return table_;
  }
  toml::table table_;
};

std::string message(const TomlReader& r) { return r.error ? r.error->message : std::string("(no error)"); }

TEST(ParseToml, ASyntaxErrorNamesTheSourceAndLine) {
  auto bad = parse_toml("a = 1\nb = \n", "t.toml");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, ErrorCode::kInvalidInput);
  EXPECT_EQ(bad.error().message.rfind("t.toml:2: ", 0), 0u) << bad.error().message;
  auto twice = parse_toml("a = 1\na = 2\n", "t.toml");
  ASSERT_FALSE(twice.ok());
  EXPECT_EQ(twice.error().message.rfind("t.toml:2: ", 0), 0u) << twice.error().message;
}

TEST_F(TomlReaderTest, WhereGivesTheLineWhenTheKeyIsThere) {
  TomlReader r(parse("\n\nspeed = 3\n"), "t.toml", "nc.");
  EXPECT_EQ(r.where("speed"), "t.toml:3: key `nc.speed`");
  EXPECT_EQ(r.where("absent"), "t.toml: key `nc.absent`");
  EXPECT_TRUE(r.has("speed"));
  EXPECT_FALSE(r.has("absent"));
}

TEST_F(TomlReaderTest, ReadsEachTypeAndFallsBackWhenAbsent) {
  TomlReader r(parse("s = \"x\"\nb = false\nn = 2.5\ni = 0x10\nwhole = 4\nc = \"two\"\n[t]\nk = 1\n"), "t.toml");
  EXPECT_EQ(r.text("s", "d"), "x");
  EXPECT_EQ(r.text("absent", "d"), "d");
  EXPECT_FALSE(r.flag("b", true));
  EXPECT_TRUE(r.flag("absent", true));
  EXPECT_EQ(r.number("n", 0.0, 0.0, 10.0), 2.5);
  EXPECT_EQ(r.number("whole", 0.0, 0.0, 10.0), 4.0) << "an integer is a number";
  EXPECT_EQ(r.number("absent", 7.0, 0.0, 10.0), 7.0);
  EXPECT_EQ(r.integer("i", 0, 0, 100), 16) << "hex";
  EXPECT_EQ(r.integer("absent", 5, 0, 100), 5);
  EXPECT_EQ(r.choice("c", "one", {"one", "two"}), "two");
  EXPECT_EQ(r.choice("absent", "one", {"one", "two"}), "one");
  const toml::table* t = r.subtable("t");
  ASSERT_NE(t, nullptr);
  EXPECT_TRUE(t->contains("k"));
  EXPECT_EQ(r.subtable("absent"), nullptr);
  EXPECT_FALSE(r.error.has_value()) << message(r);
}

TEST_F(TomlReaderTest, ARequiredKeyMissingIsNamed) {
  TomlReader r(parse(""), "t.toml", "part.");
  EXPECT_EQ(r.text("file", std::nullopt), "");
  EXPECT_EQ(message(r), "t.toml: key `part.file` is missing; it is required");
  TomlReader n(table_, "t.toml");
  EXPECT_EQ(n.number("x", std::nullopt, 0.0, 1.0), 0.0);
  EXPECT_EQ(message(n), "t.toml: key `x` is missing; it is required");
  TomlReader i(table_, "t.toml");
  EXPECT_EQ(i.integer("x", std::nullopt, 0, 1), 0);
  EXPECT_EQ(message(i), "t.toml: key `x` is missing; it is required");
}

TEST_F(TomlReaderTest, AWrongTypeSaysWhatIsExpected) {
  parse("s = 1\nb = \"true\"\nn = \"1.0\"\ni = 1.5\nt = 3\nnan = nan\ninf = -inf\n");
  const auto first_error = [this](auto read) {
    TomlReader r(table_, "t.toml", "x.");
    read(r);
    return message(r);
  };
  EXPECT_EQ(first_error([](TomlReader& r) { (void)r.text("s", "d"); }),
            "t.toml:1: key `x.s`: expected a string in quotes");
  EXPECT_EQ(first_error([](TomlReader& r) { (void)r.flag("b", false); }),
            "t.toml:2: key `x.b`: expected true or false (no quotes)");
  EXPECT_EQ(first_error([](TomlReader& r) { (void)r.number("n", 0.0, 0.0, 9.0); }),
            "t.toml:3: key `x.n`: expected a number");
  EXPECT_EQ(first_error([](TomlReader& r) { (void)r.integer("i", 0, 0, 9); }),
            "t.toml:4: key `x.i`: expected a whole number (hex like 0x0001 is fine)");
  EXPECT_EQ(first_error([](TomlReader& r) { (void)r.subtable("t"); }), "t.toml:5: key `x.t`: expected a table ([x.t])");
  EXPECT_EQ(first_error([](TomlReader& r) { (void)r.number("nan", 0.0, -1e9, 1e9); }),
            "t.toml:6: key `x.nan`: expected a number");
  EXPECT_EQ(first_error([](TomlReader& r) { (void)r.number("inf", 0.0, -1e300, 1e300); }),
            "t.toml:7: key `x.inf`: expected a number");
}

TEST_F(TomlReaderTest, OutOfRangeSaysTheAllowedInterval) {
  TomlReader closed(parse("a = 0\nb = 11\nc = -1\nd = 0.0\n"), "t.toml");
  (void)closed.number("a", 1.0, 0.0, 10.0);
  EXPECT_FALSE(closed.error.has_value()) << "the closed minimum is allowed: " << message(closed);
  (void)closed.integer("b", 0, 0, 10);
  EXPECT_EQ(message(closed), "t.toml:2: key `b`: 11 is out of range; allowed [0, 10]");
  TomlReader open(table_, "t.toml");
  (void)open.number("d", 1.0, 0.0, 10.0, true);
  EXPECT_EQ(message(open), "t.toml:4: key `d`: 0 is out of range; allowed (0, 10]");
  TomlReader below(table_, "t.toml");
  (void)below.number("c", 1.0, 0.0, 0.5);
  EXPECT_EQ(message(below), "t.toml:3: key `c`: -1 is out of range; allowed [0, 0.5]");
}

TEST_F(TomlReaderTest, AChoiceNotListedNamesTheChoices) {
  TomlReader r(parse("mode = \"fast\"\n"), "t.toml", "gauge.");
  EXPECT_EQ(r.choice("mode", "live", {"latched", "live"}), "fast");
  EXPECT_EQ(message(r), "t.toml:1: key `gauge.mode`: `fast` is not one of latched, live");
}

TEST_F(TomlReaderTest, UnknownKeysAreRefusedListingTheKnownOnes) {
  TomlReader r(parse("host = \"h\"\nprot = 502\n"), "t.toml", "link.");
  r.allow_only({"host", "port"});
  EXPECT_EQ(message(r), "t.toml:2: key `link.prot`: unknown key; known keys: host, port");
  TomlReader fine(table_, "t.toml");
  fine.allow_only({"host", "prot", "other"});
  EXPECT_FALSE(fine.error.has_value()) << message(fine);
}

// The first problem is the one reported; reads after it still return their fallbacks, so a
// caller reads every key and checks once.
TEST_F(TomlReaderTest, TheFirstErrorIsKept) {
  TomlReader r(parse("a = \"x\"\nb = \"y\"\n"), "t.toml");
  EXPECT_EQ(r.integer("a", 3, 0, 9), 0);
  EXPECT_EQ(r.integer("b", 3, 0, 9), 0);
  EXPECT_EQ(r.integer("absent", 3, 0, 9), 3);
  r.fail("later");
  EXPECT_EQ(message(r), "t.toml:1: key `a`: expected a whole number (hex like 0x0001 is fine)");
  EXPECT_EQ(r.error->code, ErrorCode::kInvalidInput);
}

}  // namespace
}  // namespace gaugeloop
