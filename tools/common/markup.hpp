// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Escaping text for the markup adit writes (the animated page's HTML, the pictures' SVG): the
/// five characters with a meaning in markup become entities, and control characters other than
/// tab and newline, which XML 1.0 forbids and no label needs, are dropped.

#include <string>

namespace adit::tools {

inline std::string htmlEscape(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default:
        if (static_cast<unsigned char>(c) >= 0x20 || c == '\t' || c == '\n') out += c;
    }
  }
  return out;
}

}  // namespace adit::tools
