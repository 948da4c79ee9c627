// SPDX-License-Identifier: BSD-3-Clause
#include "adit/console/store.hpp"

namespace adit::console {

const char* commandStatusName(CommandStatus s) {
  switch (s) {
    case CommandStatus::kPending: return "pending";
    case CommandStatus::kSent: return "sent";
    case CommandStatus::kAccepted: return "accepted";
    case CommandStatus::kRefused: return "refused";
    case CommandStatus::kExecuted: return "executed";
  }
  return "?";
}

std::optional<CommandStatus> parseCommandStatus(const std::string& name) {
  for (CommandStatus s : {CommandStatus::kPending, CommandStatus::kSent, CommandStatus::kAccepted,
                          CommandStatus::kRefused, CommandStatus::kExecuted})
    if (name == commandStatusName(s)) return s;
  return std::nullopt;
}

}  // namespace adit::console
