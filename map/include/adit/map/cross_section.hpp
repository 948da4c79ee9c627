// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Roadway cross-sections as mine surveyors specify them. Coordinates are in the section plane:
/// u lateral (0 on the centreline), v up from the floor (the floor is flat across the section).
/// Every shape is symmetric and convex, so it is described by its half-width at each height.
///
///   CrossSection gate = CrossSection::rectangle(4.5, 3.5);
///   bool inside = gate.contains(1.0, 2.0);          // true
///   double half = gate.halfWidthAt(1.0);            // 2.25

#include <string>

#include "adit/status.hpp"

namespace adit::map {

enum class SectionShape {
  kArch,              ///< vertical walls and a semicircular roof (rise = width / 2)
  kRectangle,
  kTrapezoid,         ///< wider at the floor than at the roof (or the other way round)
  kThreeCentredArch,  ///< vertical walls and a roof of three tangent arcs
};

const char* sectionShapeName(SectionShape s);

class CrossSection {
 public:
  /// Semicircular arch: walls `wall_height` tall, then a half circle of diameter `width`.
  static CrossSection arch(double width, double wall_height);
  static CrossSection rectangle(double width, double height);
  static CrossSection trapezoid(double bottom_width, double top_width, double height);
  /// Three-centred arch of span `width` and `rise` above the springing line. Of the family of
  /// such arches we use the one of the Chinese coal-mine standard, whose crown arc subtends
  /// 2 * atan(2 rise / width): rise = width/3 gives R = 0.692 width, r = 0.262 width.
  static CrossSection threeCentredArch(double width, double wall_height, double rise);

  /// Finite, positive dimensions and a constructible shape; the message names the field.
  Status validate() const;

  SectionShape shape() const { return shape_; }
  double height() const;        ///< floor to crown [m]
  double maxWidth() const;      ///< widest point [m]
  double halfWidthAt(double v) const;  ///< 0 outside [0, height]
  bool contains(double u, double v) const;
  double area() const;          ///< [m^2], by integration of the half-width

  // Parameters as given (unused ones are 0).
  double width = 0.0, wall_height = 0.0, height_param = 0.0;
  double bottom_width = 0.0, top_width = 0.0, rise = 0.0;

 private:
  SectionShape shape_ = SectionShape::kRectangle;
  // Derived for the three-centred arch: haunch radius, crown radius, crown half-angle.
  double haunch_r_ = 0.0, crown_r_ = 0.0, crown_half_angle_ = 0.0;
  void derive();
};

}  // namespace adit::map
