#include "core/uuid.h"

#include <gtest/gtest.h>

#include <set>
#include <string>
#include <thread>
#include <vector>

namespace gaugeloop {
namespace {

TEST(Uuid, IsCanonicalVersion4Text) {
  for (int i = 0; i < 1000; ++i) {
    const std::string u = new_uuid();
    ASSERT_TRUE(is_uuid(u)) << u;
    EXPECT_EQ(u[14], '4') << u;                                          // version nibble
    EXPECT_NE(std::string("89ab").find(u[19]), std::string::npos) << u;  // RFC variant
  }
}

TEST(Uuid, NeverRepeatsAcrossThreads) {
  // 4 x 20000 draws of 122 random bits: any repeat means the generator is shared or seeded
  // alike, which is exactly what would make two grinders' records collide.
  std::vector<std::vector<std::string>> drawn(4);
  std::vector<std::thread> threads;
  for (auto& out : drawn) {
    threads.emplace_back([&out] {
      for (int i = 0; i < 20000; ++i) out.push_back(new_uuid());
    });
  }
  for (auto& t : threads) t.join();
  std::set<std::string> all;
  for (const auto& out : drawn) all.insert(out.begin(), out.end());
  EXPECT_EQ(all.size(), 80000u);
}

TEST(Uuid, RefusesWhatIsNotTheCanonicalForm) {
  EXPECT_TRUE(is_uuid("123e4567-e89b-42d3-a456-426614174000"));
  EXPECT_FALSE(is_uuid("123E4567-E89B-42D3-A456-426614174000"));  // upper case
  EXPECT_FALSE(is_uuid("123e4567e89b42d3a456426614174000"));      // no hyphens
  EXPECT_FALSE(is_uuid("123e4567-e89b-42d3-a456-42661417400"));   // short
  EXPECT_FALSE(is_uuid("123e4567-e89b-42d3-a456-42661417400g"));  // not hex
  EXPECT_FALSE(is_uuid(""));
}

}  // namespace
}  // namespace gaugeloop
