#include "core/utf8.h"

#include <gtest/gtest.h>

#include <string>

namespace gaugeloop {
namespace {

TEST(Utf8, ValidTextIsKeptByteForByte) {
  const std::string text = "Ma\xC3\x9F \xE2\x80\x94 \xF0\x9F\x94\xA7 x";  // ß, an em dash, a wrench
  EXPECT_EQ(with_valid_utf8(text), text);
  char32_t cp = 0;
  EXPECT_EQ(utf8_sequence_at(text, 2, cp), 2u);
  EXPECT_EQ(cp, U'\u00DF');
  EXPECT_EQ(utf8_sequence_at(text, 9, cp), 4u);
  EXPECT_EQ(cp, U'\U0001F527');
}

TEST(Utf8, EachStrayByteBecomesOneReplacementCharacter) {
  EXPECT_EQ(with_valid_utf8("Ma\xDF"), "Ma\xEF\xBF\xBD");                              // Latin-1 ß
  EXPECT_EQ(with_valid_utf8("\xC0\xAF"), "\xEF\xBF\xBD\xEF\xBF\xBD");                  // an overlong '/'
  EXPECT_EQ(with_valid_utf8("\xED\xA0\x80"), "\xEF\xBF\xBD\xEF\xBF\xBD\xEF\xBF\xBD");  // a surrogate
  EXPECT_EQ(with_valid_utf8("ab\xE2\x80"), "ab\xEF\xBF\xBD\xEF\xBF\xBD");              // cut short
  char32_t cp = 0;
  EXPECT_EQ(utf8_sequence_at("\xF4\x90\x80\x80", 0, cp), 0u) << "above U+10FFFF";
}

}  // namespace
}  // namespace gaugeloop
