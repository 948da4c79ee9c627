// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/cross_section.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace adit::map {

namespace {
bool positiveFinite(double v) { return std::isfinite(v) && v > 0.0; }
std::string num(double v) { std::ostringstream os; os << v; return os.str(); }
}  // namespace

const char* sectionShapeName(SectionShape s) {
  switch (s) {
    case SectionShape::kArch: return "arch";
    case SectionShape::kRectangle: return "rectangle";
    case SectionShape::kTrapezoid: return "trapezoid";
    case SectionShape::kThreeCentredArch: return "three_centred_arch";
  }
  return "?";
}

CrossSection CrossSection::arch(double w, double wall_h) {
  CrossSection s; s.shape_ = SectionShape::kArch; s.width = w; s.wall_height = wall_h; s.derive(); return s;
}
CrossSection CrossSection::rectangle(double w, double h) {
  CrossSection s; s.shape_ = SectionShape::kRectangle; s.width = w; s.height_param = h; s.derive(); return s;
}
CrossSection CrossSection::trapezoid(double bottom, double top, double h) {
  CrossSection s; s.shape_ = SectionShape::kTrapezoid; s.bottom_width = bottom; s.top_width = top;
  s.height_param = h; s.derive(); return s;
}
CrossSection CrossSection::threeCentredArch(double w, double wall_h, double r) {
  CrossSection s; s.shape_ = SectionShape::kThreeCentredArch; s.width = w; s.wall_height = wall_h;
  s.rise = r; s.derive(); return s;
}

void CrossSection::derive() {
  if (shape_ != SectionShape::kThreeCentredArch) return;
  // Crown centre (0, h + f - R), haunch centres (+-(a - r), h), arcs tangent where the line of
  // centres leaves the crown centre at the crown half-angle theta from vertical:
  //   a - r = (R - r) sin(theta),  R - f = (R - r) cos(theta),  theta = atan(2 f / B).
  const double a = 0.5 * width, f = rise;
  if (!(a > 0) || !(f > 0)) return;
  crown_half_angle_ = std::atan2(2.0 * f, width);
  const double s = std::sin(crown_half_angle_), c = std::cos(crown_half_angle_);
  const double t = (1.0 - c) / s;
  haunch_r_ = (f - a * t) / (1.0 - t);
  crown_r_ = haunch_r_ + (a - haunch_r_) / s;
}

Status CrossSection::validate() const {
  const std::string n = sectionShapeName(shape_);
  switch (shape_) {
    case SectionShape::kArch:
      if (!positiveFinite(width)) return invalidArgument(n + ": width = " + num(width) + " must be finite and > 0");
      if (!std::isfinite(wall_height) || wall_height < 0)
        return invalidArgument(n + ": wall_height = " + num(wall_height) + " must be finite and >= 0");
      break;
    case SectionShape::kRectangle:
      if (!positiveFinite(width)) return invalidArgument(n + ": width = " + num(width) + " must be finite and > 0");
      if (!positiveFinite(height_param)) return invalidArgument(n + ": height = " + num(height_param) + " must be finite and > 0");
      break;
    case SectionShape::kTrapezoid:
      if (!positiveFinite(bottom_width)) return invalidArgument(n + ": bottom_width = " + num(bottom_width) + " must be finite and > 0");
      if (!positiveFinite(top_width)) return invalidArgument(n + ": top_width = " + num(top_width) + " must be finite and > 0");
      if (!positiveFinite(height_param)) return invalidArgument(n + ": height = " + num(height_param) + " must be finite and > 0");
      break;
    case SectionShape::kThreeCentredArch:
      if (!positiveFinite(width)) return invalidArgument(n + ": width = " + num(width) + " must be finite and > 0");
      if (!std::isfinite(wall_height) || wall_height < 0)
        return invalidArgument(n + ": wall_height = " + num(wall_height) + " must be finite and >= 0");
      if (!positiveFinite(rise)) return invalidArgument(n + ": rise = " + num(rise) + " must be finite and > 0");
      if (rise >= 0.5 * width)
        return invalidArgument(n + ": rise = " + num(rise) + " must be < width / 2 = " + num(0.5 * width) +
                               " (a rise of width / 2 is a semicircular 'arch')");
      if (!(haunch_r_ > 0) || !(crown_r_ > haunch_r_))
        return invalidArgument(n + ": width " + num(width) + " and rise " + num(rise) + " give no valid arcs");
      break;
  }
  return {};
}

double CrossSection::height() const {
  switch (shape_) {
    case SectionShape::kArch: return wall_height + 0.5 * width;
    case SectionShape::kRectangle:
    case SectionShape::kTrapezoid: return height_param;
    case SectionShape::kThreeCentredArch: return wall_height + rise;
  }
  return 0.0;
}

double CrossSection::maxWidth() const {
  return shape_ == SectionShape::kTrapezoid ? std::max(bottom_width, top_width) : width;
}

double CrossSection::halfWidthAt(double v) const {
  if (!(v >= 0.0) || v > height()) return 0.0;
  switch (shape_) {
    case SectionShape::kRectangle: return 0.5 * width;
    case SectionShape::kTrapezoid:
      return 0.5 * (bottom_width + (top_width - bottom_width) * (v / height_param));
    case SectionShape::kArch: {
      if (v <= wall_height) return 0.5 * width;
      const double a = 0.5 * width, dv = v - wall_height;
      return std::sqrt(std::max(0.0, a * a - dv * dv));
    }
    case SectionShape::kThreeCentredArch: {
      if (v <= wall_height) return 0.5 * width;
      const double a = 0.5 * width, dv = v - wall_height;
      const double tangent_dv = haunch_r_ * std::cos(crown_half_angle_);
      if (dv <= tangent_dv)
        return (a - haunch_r_) + std::sqrt(std::max(0.0, haunch_r_ * haunch_r_ - dv * dv));
      const double crown_centre_dv = rise - crown_r_;
      const double e = dv - crown_centre_dv;
      return std::sqrt(std::max(0.0, crown_r_ * crown_r_ - e * e));
    }
  }
  return 0.0;
}

bool CrossSection::contains(double u, double v) const {
  return v >= 0.0 && v <= height() && std::abs(u) <= halfWidthAt(v);
}

double CrossSection::area() const {
  // Simpson's rule on the half-width; 2000 panels are far below survey accuracy.
  const int n = 2000;
  const double h = height(), dv = h / n;
  double sum = halfWidthAt(0.0) + halfWidthAt(h);
  for (int i = 1; i < n; ++i) sum += (i % 2 ? 4.0 : 2.0) * halfWidthAt(i * dv);
  return 2.0 * sum * dv / 3.0;
}

}  // namespace adit::map
