// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/cross_section.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace adit::map {
namespace {

TEST(CrossSection, ArchIsWallsPlusSemicircle) {
  const CrossSection s = CrossSection::arch(5.0, 3.0);
  ASSERT_TRUE(s.validate().ok());
  EXPECT_DOUBLE_EQ(s.height(), 5.5);
  EXPECT_DOUBLE_EQ(s.halfWidthAt(1.0), 2.5);
  EXPECT_NEAR(s.halfWidthAt(3.0 + 1.5), std::sqrt(2.5 * 2.5 - 1.5 * 1.5), 1e-12);
  EXPECT_NEAR(s.area(), 5.0 * 3.0 + M_PI * 2.5 * 2.5 / 2.0, 1e-3);
  EXPECT_TRUE(s.contains(0.0, 5.4));
  EXPECT_FALSE(s.contains(2.4, 5.0));
  EXPECT_FALSE(s.contains(0.0, -0.01));
}

TEST(CrossSection, TrapezoidInterpolatesWidth) {
  const CrossSection s = CrossSection::trapezoid(4.0, 3.2, 3.0);
  ASSERT_TRUE(s.validate().ok());
  EXPECT_DOUBLE_EQ(s.halfWidthAt(0.0), 2.0);
  EXPECT_DOUBLE_EQ(s.halfWidthAt(3.0), 1.6);
  EXPECT_NEAR(s.area(), 0.5 * (4.0 + 3.2) * 3.0, 1e-6);
}

// The mining standard's tabulated three-centred arch: rise = B/3 gives R = 0.692 B, r = 0.262 B.
TEST(CrossSection, ThreeCentredArchMatchesTheStandardTable) {
  const double b = 3.0;
  const CrossSection s = CrossSection::threeCentredArch(b, 2.0, b / 3.0);
  ASSERT_TRUE(s.validate().ok()) << s.validate().toString();
  EXPECT_DOUBLE_EQ(s.height(), 3.0);
  EXPECT_NEAR(s.halfWidthAt(2.0), 1.5, 1e-12);          // springing line
  EXPECT_NEAR(s.halfWidthAt(3.0), 0.0, 1e-6);           // crown
  // The profile is continuous and non-increasing above the springing line.
  double prev = s.halfWidthAt(2.0);
  for (double v = 2.0; v <= 2.99; v += 0.001) {
    const double w = s.halfWidthAt(v);
    EXPECT_LE(w, prev + 1e-9);
    EXPECT_LT(prev - w, 0.06);
    prev = w;
  }
  // Tabulated area for f = B/3: 0.262 B^2 above the springing line (a semi-ellipse, 0.2618 B^2).
  EXPECT_NEAR(s.area() - b * 2.0, 0.262 * b * b, 0.003 * b * b);
  // f = B/4 is tabulated as 0.198 B^2.
  const CrossSection flat = CrossSection::threeCentredArch(b, 2.0, b / 4.0);
  EXPECT_NEAR(flat.area() - b * 2.0, 0.198 * b * b, 0.003 * b * b);
}

TEST(CrossSection, ValidateNamesTheBadField) {
  EXPECT_NE(CrossSection::rectangle(-1, 3).validate().message().find("width"), std::string::npos);
  EXPECT_NE(CrossSection::rectangle(4, NAN).validate().message().find("height"), std::string::npos);
  EXPECT_NE(CrossSection::arch(4, -1).validate().message().find("wall_height"), std::string::npos);
  EXPECT_NE(CrossSection::trapezoid(4, 0, 3).validate().message().find("top_width"), std::string::npos);
  EXPECT_NE(CrossSection::threeCentredArch(4, 2, 2.5).validate().message().find("rise"), std::string::npos);
  EXPECT_FALSE(CrossSection::threeCentredArch(4, 2, 0).validate().ok());
}

}  // namespace
}  // namespace adit::map
