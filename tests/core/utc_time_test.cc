// UTC times as gaugeloop writes and reads them.
#include "core/utc_time.h"

#include <gtest/gtest.h>

namespace gaugeloop {
namespace {

TEST(UtcTime, FormatsAndReadsBackTheSameSecond) {
  EXPECT_EQ(format_utc(0), "1970-01-01T00:00:00Z");
  EXPECT_EQ(format_utc(1795054484), "2026-11-19T02:14:44Z");
  ASSERT_TRUE(epoch_of_utc("2026-11-19T02:14:44Z").has_value());
  EXPECT_EQ(*epoch_of_utc("2026-11-19T02:14:44Z"), 1795054484);
  EXPECT_FALSE(epoch_of_utc("2026-11-19 02:54:44").has_value());
  EXPECT_FALSE(epoch_of_utc("2026-11-19T02:14:44Z trailing").has_value());
}

TEST(UtcTime, NowIsATimestampAndFileStampsHaveNoColons) {
  EXPECT_TRUE(is_utc_timestamp(utc_now()));
  const std::string stamp = utc_file_stamp();
  EXPECT_EQ(stamp.size(), 16u);
  EXPECT_EQ(stamp.find(':'), std::string::npos);
}

TEST(UtcTime, OnlyTheFixedWidthShapeWithPlausibleFieldsIsATimestamp) {
  EXPECT_TRUE(is_utc_timestamp("2026-12-31T23:59:60Z"));  // a leap second
  EXPECT_FALSE(is_utc_timestamp("2026-13-01T00:00:00Z"));
  EXPECT_FALSE(is_utc_timestamp("2026-12-00T00:00:00Z"));
  EXPECT_FALSE(is_utc_timestamp("2026-12-01T24:00:00Z"));
  EXPECT_FALSE(is_utc_timestamp("2026-12-01T00:00:00"));
  EXPECT_FALSE(is_utc_timestamp("2026-1-01T00:00:00Z"));
}

}  // namespace
}  // namespace gaugeloop
