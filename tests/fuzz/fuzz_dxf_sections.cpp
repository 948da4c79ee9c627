// SPDX-License-Identifier: BSD-3-Clause
// Sections YAML / --section text -> parseDxfSections and parseSectionSpec (both build a stub
// survey around the user's text; the text must not be able to break out of it).
#include <cstddef>
#include <cstdint>
#include <string>

#include "adit/map/readers/dxf.hpp"
#include "fuzz_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace adit::map;
  const std::string text(reinterpret_cast<const char*>(data), size);
  adit::StatusOr<DxfSections> s = parseDxfSections(text, "fuzz_sections.yaml");
  if (s.ok() && s->by_layer.empty()) adit::fuzz::broken("sections YAML parsed ok without sections");
  adit::StatusOr<CrossSection> spec = parseSectionSpec(text);
  if (spec.ok() && !spec->validate().ok()) adit::fuzz::broken("invalid --section accepted");
  return 0;
}
