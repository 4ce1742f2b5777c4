// Decoding values in each type and word order, grouping fields into requests, and map checks.
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

TEST(FieldDecode, DecodesEveryTypeWithSign) {
  const std::array<std::uint16_t, 2> minus_two = {0xFFFF, 0xFFFE};
  FieldSpec f;
  f.type = ValueType::kInt16;
  EXPECT_EQ(decode_raw(f, std::span<const std::uint16_t>(minus_two).subspan(1)), -2.0);
  f.type = ValueType::kUInt16;
  EXPECT_EQ(decode_raw(f, std::span<const std::uint16_t>(minus_two).subspan(1)), 65534.0);
  f.type = ValueType::kInt32;
  EXPECT_EQ(decode_raw(f, minus_two), -2.0);
  f.type = ValueType::kUInt32;
  EXPECT_EQ(decode_raw(f, minus_two), 4294967294.0);
  f.type = ValueType::kFloat32;
  f.order = WordOrder::kCDAB;
  const std::array<std::uint16_t, 2> one_and_half = {0x0000, 0x3FC0};
  EXPECT_EQ(decode_raw(f, one_and_half), 1.5);
}

TEST(StatusMasks, TranslateTheAmplifiersBitsToOurs) {
  StatusMasks m;  // simulator: ready bit 0, over 1, under 2, probe missing 3
  EXPECT_EQ(translate_status(0x0001, m), kGaugeReady);
  EXPECT_EQ(translate_status(0x0003, m), kGaugeReady | kGaugeOverRange);
  EXPECT_EQ(translate_status(0x0000, m), 0);
  StatusMasks other;  // another amplifier's layout
  other.ready = 0x8000;
  other.over_range = 0x0100;
  other.under_range = 0x0200;
  other.probe_missing = 0x0400;
  EXPECT_EQ(translate_status(0x8400, other), kGaugeReady | kGaugeProbeMissing);
  EXPECT_FALSE(gauge_status_ok(translate_status(0x0001, other))) << "bit 0 means nothing to this amplifier";
}

// Many amplifiers report 0 for "ok" and one bit per fault of their own.
TEST(StatusMasks, AnOkValueAndNamedBitsDescribeAnotherKindOfStatusWord) {
  StatusMasks m;
  m.ok_value = 0;
  m.bit_names[0] = "over-range";
  m.bit_names[5] = "coil open";
  EXPECT_TRUE(gauge_status_ok(translate_status(0x0000, m)));
  const GaugeStatus coil = translate_status(0x0020, m);
  EXPECT_FALSE(gauge_status_ok(coil));
  EXPECT_EQ(describe_gauge_status(coil, &m.bit_names), "coil open") << "not \"over-range\": the bit has its own name";
  EXPECT_EQ(describe_gauge_status(translate_status(0x0201, m), &m.bit_names), "over-range, status bit 9");
  EXPECT_EQ(describe_gauge_status(translate_status(0x0201, m)), "status bit 0, status bit 9") << "no names given";

  StatusMasks ready_bit;  // ok is 0x8000, the ready bit alone
  ready_bit.ok_value = 0x8000;
  EXPECT_TRUE(gauge_status_ok(translate_status(0x8000, ready_bit)));
  EXPECT_EQ(describe_gauge_status(translate_status(0x0000, ready_bit)), "not ready");
  EXPECT_EQ(describe_gauge_status(translate_status(0x8004, ready_bit)), "status bit 2");
}

TEST(SnapshotBlocks, TheSimulatorsContiguousFieldsAreOneRequest) {
  const auto blocks = snapshot_blocks(RegisterMap{});
  ASSERT_EQ(blocks.size(), 1u);
  EXPECT_EQ(blocks[0].table, RegisterTable::kInput);
  EXPECT_EQ(blocks[0].start, 0);
  EXPECT_EQ(blocks[0].count, 7);
}

TEST(SnapshotBlocks, SplitsByTableAndByDistantAddresses) {
  RegisterMap m;
  m.reading = {true, RegisterTable::kHolding, 40, ValueType::kFloat32, WordOrder::kCDAB, 1.0, 0.0};
  m.status.address = 200;  // input, far from angle at 3
  const auto blocks = snapshot_blocks(m);
  ASSERT_EQ(blocks.size(), 3u);
  EXPECT_EQ(blocks[0].table, RegisterTable::kHolding);
  EXPECT_EQ(blocks[0].start, 40);
  EXPECT_EQ(blocks[0].count, 2);
  EXPECT_EQ(blocks[1].start, 3);  // angle 3-4, revolution 5, sequence 6
  EXPECT_EQ(blocks[1].count, 4);
  EXPECT_EQ(blocks[2].start, 200);
}

TEST(Snapshot, DecodesTheSimulatorBlock) {
  // reading -12345 counts (= -1.2345 mm), status ready, angle 123.456 deg, rev 7, seq 9
  const std::uint32_t reading = static_cast<std::uint32_t>(-12345);
  const RegisterMap map;
  const auto blocks = snapshot_blocks(map);
  const std::vector<std::vector<std::uint16_t>> words = {{static_cast<std::uint16_t>(reading >> 16),
                                                          static_cast<std::uint16_t>(reading & 0xffff), 1, 0x0001,
                                                          static_cast<std::uint16_t>(123456 - 65536), 7, 9}};
  GaugeSnapshot s = decode_snapshot(map, blocks, words, 0);
  EXPECT_NEAR(s.reading_mm, -1.2345, 1e-12);
  EXPECT_NEAR(s.angle_deg, 123.456, 1e-9);
  EXPECT_EQ(s.status, kGaugeReady);
  EXPECT_EQ(s.revolution, 7);
  EXPECT_EQ(s.sequence, 9);
}

TEST(Snapshot, MissingOptionalFieldsHaveStandIns) {
  RegisterMap m;
  m.status.present = false;
  m.sequence.present = false;
  const auto blocks = snapshot_blocks(m);
  const std::vector<std::vector<std::uint16_t>> words = {{0, 10, 0, 0, 1000, 3}};
  ASSERT_EQ(blocks[0].count, 6);
  GaugeSnapshot s = decode_snapshot(m, blocks, words, 41);
  EXPECT_EQ(s.status, kGaugeReady) << "no status word: always ready";
  EXPECT_EQ(s.sequence, 41) << "no sequence: the poll count, so every poll is a new sample";
  EXPECT_NEAR(s.angle_deg, 1.0, 1e-12);
}

TEST(LatchedDecode, FollowsTheEntryLayoutAndTheReadingField) {
  RegisterMap m;
  m.reading = {true, RegisterTable::kHolding, 0, ValueType::kFloat32, WordOrder::kCDAB, 1.0, 0.5};
  m.latch.entry_words = 3;
  m.latch.degree_offset = 0;
  m.latch.reading_offset = 1;
  m.latch.status_offset = -1;
  const std::vector<std::uint16_t> regs = {359, 0x0000, 0x3FC0, 0, 0x0000, 0x4000};
  const auto e = decode_latched(m, regs);
  ASSERT_EQ(e.size(), 2u);
  EXPECT_EQ(e[0].degree, 359);
  EXPECT_DOUBLE_EQ(e[0].reading_mm, 2.0);  // 1.5 + offset 0.5
  EXPECT_EQ(e[1].degree, 0);
  EXPECT_DOUBLE_EQ(e[1].reading_mm, 2.5);
  EXPECT_EQ(e[1].status, kGaugeReady);
}

// Compact entries: the reading alone; the degree comes from the latch number (poller).
TEST(LatchedDecode, CompactEntriesCarryNoDegree) {
  RegisterMap m;
  m.latch.entry_words = 2;
  m.latch.degree_offset = kDegreeImpliedByCount;
  m.latch.status_offset = -1;
  m.latch.fault_count_address = 105;
  ASSERT_TRUE(validate(m).ok()) << validate(m).error().message;
  const std::uint32_t minus = static_cast<std::uint32_t>(-25);  // -2.5 um
  const std::vector<std::uint16_t> regs = {0x0001, 0x86A0,      // 100000 counts = 10 mm
                                           static_cast<std::uint16_t>(minus >> 16),
                                           static_cast<std::uint16_t>(minus & 0xffff)};
  const auto e = decode_latched(m, regs);
  ASSERT_EQ(e.size(), 2u);
  EXPECT_DOUBLE_EQ(e[0].reading_mm, 10.0);
  EXPECT_DOUBLE_EQ(e[1].reading_mm, -0.0025);
  EXPECT_EQ(e[0].degree, kDegreeImpliedByCount);
  EXPECT_EQ(e[1].status, kGaugeReady) << "no status word in the entry: the fault counter speaks for it";
  EXPECT_EQ(latched_entries_per_read(m), 62);
}

TEST(LatchedDecode, CompactEntryWithAFloatReadingAndAStatusWord) {
  RegisterMap m;
  m.reading = {true, RegisterTable::kHolding, 0, ValueType::kFloat32, WordOrder::kCDAB, 1.0, 0.0};
  m.latch.entry_words = 3;
  m.latch.degree_offset = kDegreeImpliedByCount;
  m.latch.reading_offset = 0;
  m.latch.status_offset = 2;
  ASSERT_TRUE(validate(m).ok()) << validate(m).error().message;
  const std::vector<std::uint16_t> regs = {0x0000, 0x3FC0, 0x0003};
  const auto e = decode_latched(m, regs);
  ASSERT_EQ(e.size(), 1u);
  EXPECT_DOUBLE_EQ(e[0].reading_mm, 1.5);
  EXPECT_EQ(e[0].status, kGaugeReady | kGaugeOverRange);
}

// The simulator's compact header: count 100-101, ring size 104, fault marks 105-106, the
// latest fault mark's status 107: one request of 8 registers.
TEST(LatchState, TheCountRingSizeAndFaultCounterAreOneRequest) {
  RegisterMap m;
  m.latch.ring_size_address = 104;
  m.latch.entry_words = 2;
  m.latch.degree_offset = kDegreeImpliedByCount;
  m.latch.status_offset = -1;
  m.latch.fault_count_address = 105;
  m.latch.fault_status_address = 107;
  const auto blocks = latch_state_blocks(m);
  ASSERT_EQ(blocks.size(), 1u);
  EXPECT_EQ(blocks[0].start, 100);
  EXPECT_EQ(blocks[0].count, 8);
  const std::vector<std::vector<std::uint16_t>> words = {{0x0001, 0x0002, 512, 4, 1024, 0, 7, 0x0009}};
  const LatchState st = decode_latch_state(m, blocks, words);
  EXPECT_EQ(st.write_count, 0x00010002u);
  EXPECT_EQ(st.ring_size, 1024);
  EXPECT_TRUE(st.degree_implied);
  ASSERT_TRUE(st.fault_count.has_value());
  EXPECT_EQ(*st.fault_count, 7u);
  ASSERT_TRUE(st.fault_status.has_value());
  EXPECT_EQ(*st.fault_status, kGaugeReady | kGaugeProbeMissing);
  EXPECT_EQ(st.entries_per_read, 62);
  // The labelled default: count and ring size, no fault counter.
  const RegisterMap def;
  const auto def_blocks = latch_state_blocks(def);
  ASSERT_EQ(def_blocks.size(), 1u);
  EXPECT_EQ(def_blocks[0].count, 3);
  EXPECT_FALSE(decode_latch_state(def, def_blocks, {{0, 5, 512}}).fault_count.has_value());
}

struct BadMap {
  const char* expected;
  void (*spoil)(RegisterMap&);
};

TEST(RegisterMapValidation, RefusesBrokenMapsNamingTheField) {
  const BadMap cases[] = {
      {"`reading` is required", [](RegisterMap& m) { m.reading.present = false; }},
      {"`angle` is required", [](RegisterMap& m) { m.angle.present = false; }},
      {"`reading` and `status` overlap at input register 1", [](RegisterMap& m) { m.status.address = 1; }},
      {"`revolution` must be UINT16 or UINT32, not FLOAT32",
       [](RegisterMap& m) { m.revolution.type = ValueType::kFloat32; }},
      {"`angle` needs a finite, non-zero scale", [](RegisterMap& m) { m.angle.scale = 0.0; }},
      {"latch entry layout", [](RegisterMap& m) { m.latch.degree_offset = 4; }},
      {"latch entry layout: the reading and the degree overlap at offset 1",
       [](RegisterMap& m) { m.latch.degree_offset = 1; }},
      {"latch: compact entries (degree_offset = -1) without a status word",
       [](RegisterMap& m) {
         m.latch.entry_words = 2;
         m.latch.degree_offset = kDegreeImpliedByCount;
         m.latch.status_offset = -1;
       }},
      {"`fault_status_address` needs `fault_count_address`",
       [](RegisterMap& m) { m.latch.fault_status_address = 107; }},
      {"`fault_count_address` overlaps the latch count", [](RegisterMap& m) { m.latch.fault_count_address = 101; }},
  };
  EXPECT_TRUE(validate(RegisterMap{}).ok());
  for (const BadMap& c : cases) {
    RegisterMap m;
    c.spoil(m);
    Status s = validate(m);
    ASSERT_FALSE(s.ok()) << c.expected;
    EXPECT_NE(s.error().message.find(c.expected), std::string::npos) << s.error().message;
  }
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
