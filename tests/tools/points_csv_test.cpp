// SPDX-License-Identifier: BSD-3-Clause
// The points lists of `adit map query`: CSV quirks real files have, errors naming the line, and
// coordinates printed round-trip exact.
#include "common/points_csv.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <limits>
#include <random>

namespace adit::tools {
namespace {

using map::Vec3;

TEST(PointsCsv, Utf8ByteOrderMarkBeforeTheHeaderIsAccepted) {
  const StatusOr<std::vector<Vec3>> pts = parsePointsCsv("\xEF\xBB\xBFx,y,z\r\n1,2,3\r\n4.5,-6,7e1\r\n", "bom.csv");
  ASSERT_TRUE(pts.ok()) << pts.status().toString();
  ASSERT_EQ(pts->size(), 2u);
  EXPECT_EQ((*pts)[1], Vec3(4.5, -6, 70));
  // Without a header as well.
  const StatusOr<std::vector<Vec3>> bare = parsePointsCsv("\xEF\xBB\xBF" "1,2,3\n", "bom.csv");
  ASSERT_TRUE(bare.ok()) << bare.status().toString();
  EXPECT_EQ(bare->front(), Vec3(1, 2, 3));
}

TEST(PointsCsv, ErrorsNameTheLine) {
  struct Case { const char* text; const char* expect; };
  for (const Case& c : {Case{"x,y,z\n1,2,3\n1,2\n", "p.csv:3: expected x,y,z"},
                        Case{"1,2,3\n# c\n1,nan,3\n", "p.csv:3: coordinate 'nan' is not finite"},
                        Case{"1,2,3,4\n", "p.csv:1: expected three values"},
                        Case{"1,2,3\nx,y,z\n", "p.csv:2: 'x' is not a number"},
                        Case{"", "p.csv: no points"}, Case{"\xEF\xBB\xBF", "p.csv: no points"},
                        Case{"x,y,z\n", "p.csv: no points"}}) {
    const StatusOr<std::vector<Vec3>> r = parsePointsCsv(c.text, "p.csv");
    ASSERT_FALSE(r.ok()) << c.text;
    EXPECT_NE(r.status().message().find(c.expect), std::string::npos) << r.status().message();
  }
}

TEST(RoundTripNumber, ShortestTextThatReadsBackExactly) {
  EXPECT_EQ(roundTripNumber(1234.5678), "1234.5678");
  EXPECT_EQ(roundTripNumber(5), "5");
  EXPECT_EQ(roundTripNumber(0.1), "0.1");
  EXPECT_EQ(roundTripNumber(-0.30000000000000004), "-0.30000000000000004");
  EXPECT_EQ(roundTripNumber(4000000.125), "4000000.125");
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1e7, 1e7);
  for (int i = 0; i < 10000; ++i) {
    const double v = u(rng);
    EXPECT_EQ(std::strtod(roundTripNumber(v).c_str(), nullptr), v);
  }
  EXPECT_EQ(std::strtod(roundTripNumber(std::numeric_limits<double>::denorm_min()).c_str(), nullptr),
            std::numeric_limits<double>::denorm_min());
}

}  // namespace
}  // namespace adit::tools
