// SPDX-License-Identifier: BSD-3-Clause
#include "adit/local/subgoal.hpp"

#include <algorithm>

namespace adit::local {

void SubgoalStats::add(const std::string& kind, double us) {
  time_mean_us += (us - time_mean_us) / double(++periods);
  time_max_us = std::max(time_max_us, us);
  for (auto& [k, n] : by_kind)
    if (k == kind) {
      ++n;
      return;
    }
  by_kind.emplace_back(kind, 1);
}

}  // namespace adit::local
