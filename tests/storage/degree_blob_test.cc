// The compact per-degree BLOB: 360 big-endian int32 counts of 0.1 nm.
#include "storage/degree_blob.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

namespace gaugeloop::storage_internal {
namespace {

TEST(DegreeBlob, RoundTripsToHalfACount) {
  DegreeTable t{};
  for (std::size_t d = 0; d < t.size(); ++d) t[d] = -7.0 + static_cast<double>(d) * 0.0412345678;
  std::string blob;
  ASSERT_TRUE(append_degree_blob(t, kCountsPerMm, "t", blob).ok());
  ASSERT_EQ(blob.size(), kDegreeBlobBytes);
  Result<DegreeTable> back = read_degree_blob(blob, 0, kCountsPerMm);
  ASSERT_TRUE(back.ok()) << back.error().message;
  for (std::size_t d = 0; d < t.size(); ++d) EXPECT_NEAR((*back)[d], t[d], 0.5e-7 + 1e-12) << d;
}

TEST(DegreeBlob, IsBigEndianTwosComplement) {
  DegreeTable t{};
  t[0] = -1e-4;  // -1 count of um
  t[1] = 1.0;    // 10000 counts = 0x2710
  std::string blob;
  ASSERT_TRUE(append_degree_blob(t, kCountsPerUm, "t", blob).ok());
  EXPECT_EQ(static_cast<unsigned char>(blob[0]), 0xff);
  EXPECT_EQ(static_cast<unsigned char>(blob[3]), 0xff);
  EXPECT_EQ(static_cast<unsigned char>(blob[6]), 0x27);
  EXPECT_EQ(static_cast<unsigned char>(blob[7]), 0x10);
}

TEST(DegreeBlob, TablesFollowOneAnotherAtTheirOffsets) {
  DegreeTable a{};
  DegreeTable b{};
  a.fill(1.0);
  b.fill(-2.0);
  std::string blob;
  ASSERT_TRUE(append_degree_blob(a, kCountsPerMm, "a", blob).ok());
  ASSERT_TRUE(append_degree_blob(b, kCountsPerMm, "b", blob).ok());
  EXPECT_EQ((*read_degree_blob(blob, kDegreeBlobBytes, kCountsPerMm))[359], -2.0);
  EXPECT_FALSE(read_degree_blob(blob, kDegreeBlobBytes + 4, kCountsPerMm).ok()) << "runs past the end";
}

TEST(DegreeBlob, RefusesOutOfRangeAndNonFiniteValuesNamingTheDegree) {
  DegreeTable t{};
  t[200] = 215.0;  // mm: beyond 214.7
  std::string blob;
  Status s = append_degree_blob(t, kCountsPerMm, "mean_lift_mm", blob);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(s.error().message.find("mean_lift_mm at degree 200 is 215"), std::string::npos) << s.error().message;
  t[200] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(append_degree_blob(t, kCountsPerMm, "x", blob).ok());
  EXPECT_NEAR(degree_blob_limit(kCountsPerUm), 214748.3647, 1e-9);
}

}  // namespace
}  // namespace gaugeloop::storage_internal
