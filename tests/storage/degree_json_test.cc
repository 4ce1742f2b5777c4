// The JSON text of raw revolutions: fixed 6 decimals out, any JSON number in.
#include "storage/degree_json.h"

#include <gtest/gtest.h>

#include <clocale>
#include <string>

namespace gaugeloop::storage_internal {
namespace {

DegreeTable ramp() {
  DegreeTable t{};
  for (std::size_t d = 0; d < t.size(); ++d) t[d] = -1.0 + static_cast<double>(d) * 0.0123456789;
  return t;
}

TEST(DegreeJson, WritesSixDecimalsWithoutSpaces) {
  DegreeTable t{};
  t[0] = 1.5;
  t[1] = -0.0000004;  // rounds to -0.000000
  t[2] = 2.0000005000001;
  const std::string json = degree_table_to_json(t);
  EXPECT_EQ(json.substr(0, 40), "[1.500000,-0.000000,2.000001,0.000000,0.");
  EXPECT_EQ(json.back(), ']');
  EXPECT_EQ(json.find(' '), std::string::npos);
}

TEST(DegreeJson, RoundTripsToHalfAMicrometre) {
  const DegreeTable t = ramp();
  Result<DegreeTable> back = degree_table_from_json(degree_table_to_json(t));
  ASSERT_TRUE(back.ok()) << back.error().message;
  for (std::size_t d = 0; d < t.size(); ++d) EXPECT_NEAR((*back)[d], t[d], 0.5e-6 + 1e-12) << d;
}

TEST(DegreeJson, IgnoresTheCLocale) {
  // A locale with a decimal comma must not turn the array into "1,500000".
  const char* previous = std::setlocale(LC_NUMERIC, nullptr);
  const std::string saved = previous != nullptr ? previous : "C";
  if (std::setlocale(LC_NUMERIC, "de_DE.UTF-8") == nullptr) {
    FAIL() << "de_DE.UTF-8 locale not installed; scripts/install-deps.sh generates it";
  }
  DegreeTable t{};
  t[0] = 1.5;
  const std::string json = degree_table_to_json(t);
  std::setlocale(LC_NUMERIC, saved.c_str());
  EXPECT_EQ(json.substr(0, 10), "[1.500000,");
}

TEST(DegreeJson, ReadsHandEditedNumbers) {
  std::string json = "[ 1e-3 , -2";
  for (int i = 2; i < 360; ++i) json += ",0";
  json += " ]";
  Result<DegreeTable> t = degree_table_from_json(json);
  ASSERT_TRUE(t.ok()) << t.error().message;
  EXPECT_DOUBLE_EQ((*t)[0], 0.001);
  EXPECT_DOUBLE_EQ((*t)[1], -2.0);
}

TEST(DegreeJson, RefusesTheWrongLength) {
  Result<DegreeTable> t = degree_table_from_json("[1,2,3]");
  ASSERT_FALSE(t.ok());
  EXPECT_NE(t.error().message.find("array of 3"), std::string::npos) << t.error().message;
}

TEST(DegreeJson, RefusesNonNumbersAndBrokenText) {
  std::string json = "[null";
  for (int i = 1; i < 360; ++i) json += ",0";
  json += "]";
  Result<DegreeTable> t = degree_table_from_json(json);
  ASSERT_FALSE(t.ok());
  EXPECT_NE(t.error().message.find("element 0 is a null"), std::string::npos) << t.error().message;
  EXPECT_FALSE(degree_table_from_json("[1,2").ok());
  EXPECT_FALSE(degree_table_from_json("{}").ok());
}

}  // namespace
}  // namespace gaugeloop::storage_internal
