// Decoding 32-bit values in each word order, and the snapshot layout.
#include "acquisition/register_map.h"

#include <gtest/gtest.h>

#include <array>

namespace gaugeloop {
namespace {

// 0x12345678 as it arrives in two registers for each order (bytes A=12 B=34 C=56 D=78).
TEST(WordOrder, DecodesEachOrderOfTheSameValue) {
  EXPECT_EQ(decode_u32(0x1234, 0x5678, WordOrder::kABCD), 0x12345678u);
  EXPECT_EQ(decode_u32(0x5678, 0x1234, WordOrder::kCDAB), 0x12345678u);
  EXPECT_EQ(decode_u32(0x3412, 0x7856, WordOrder::kBADC), 0x12345678u);
  EXPECT_EQ(decode_u32(0x7856, 0x3412, WordOrder::kDCBA), 0x12345678u);
}

TEST(WordOrder, DecodesFloat32) {
  // 1.5f = 0x3FC00000
  EXPECT_EQ(decode_float32(0x3FC0, 0x0000, WordOrder::kABCD), 1.5f);
  EXPECT_EQ(decode_float32(0x0000, 0x3FC0, WordOrder::kCDAB), 1.5f);
  EXPECT_EQ(decode_float32(0xC03F, 0x0000, WordOrder::kBADC), 1.5f);
  EXPECT_EQ(decode_float32(0x0000, 0xC03F, WordOrder::kDCBA), 1.5f);
}

TEST(RegisterMap, DecodesTheSimulatorBlock) {
  // reading -12345 counts (= -1.2345 mm), status ready, angle 123.456 deg, rev 7, seq 9
  const std::uint32_t reading = static_cast<std::uint32_t>(-12345);
  const std::array<std::uint16_t, 7> regs = {static_cast<std::uint16_t>(reading >> 16),
                                             static_cast<std::uint16_t>(reading & 0xffff),
                                             1,
                                             0x0001,
                                             static_cast<std::uint16_t>(123456 - 65536),
                                             7,
                                             9};
  GaugeSnapshot s = decode_snapshot(RegisterMap{}, regs);
  EXPECT_NEAR(s.reading_mm, -1.2345, 1e-12);
  EXPECT_NEAR(s.angle_deg, 123.456, 1e-9);
  EXPECT_EQ(s.status, 1);
  EXPECT_EQ(s.revolution, 7);
  EXPECT_EQ(s.sequence, 9);
}

TEST(GaugeStatus, NamesFaultBits) {
  EXPECT_TRUE(gauge_status_ok(kGaugeReady));
  EXPECT_FALSE(gauge_status_ok(0));
  EXPECT_FALSE(gauge_status_ok(kGaugeReady | kGaugeProbeMissing));
  EXPECT_EQ(describe_gauge_status(kGaugeReady | kGaugeOverRange | kGaugeProbeMissing), "over-range, probe missing");
  EXPECT_EQ(describe_gauge_status(0), "not ready");
}

}  // namespace
}  // namespace gaugeloop
