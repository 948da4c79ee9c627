// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// The page's own files (console/web), embedded at build time by console/embed_web.cmake so that
// an installed `adit serve` needs no data directory; three.js is read from Debian's package.
#include <string>
#include <utility>
#include <vector>

namespace adit::console {
/// (file name, bytes) of every file under console/web.
const std::vector<std::pair<std::string, std::string>>& webAssets();
}  // namespace adit::console
