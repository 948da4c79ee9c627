// SPDX-License-Identifier: BSD-3-Clause
// The console's protocol messages as an attacker sends them (issue 17). Byte 0 picks the reader,
// the rest is the message text:
//   0  a robot's frame on /ws/robot: parseObject, then parseHello or parseRobotMessage, as the
//      server reads it; what it accepts is written again by toJson and must read back the same;
//   1  an operator's POST /api/commands body: parseCommandRequest;
//   2  a centre's frame on the robot's side: parseCommand (console::RobotLink).
// What a reader accepts must be in the protocol's ranges (protocol_limits.hpp): a seq in
// 1..2^53-1, a robot id of the documented form, a radius in (0, 10] m, every number finite, a goal
// within 1e7 m, a manual set-point at most 2 m/s. An accepted message out of range is a finding.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <variant>

#include "adit/console/protocol_limits.hpp"
#include "adit/console/robot_link.hpp"
#include "protocol.hpp"

namespace {

using namespace adit::console;  // NOLINT: the fuzzer's one namespace

void finiteOrAbort(const adit::map::Vec3& v, double bound) {
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(v[i]) || std::abs(v[i]) > bound) std::abort();
}

void robotFrame(const std::string& text) {
  adit::StatusOr<protocol::Json> j = protocol::parseObject(text);
  if (!j.ok()) return;
  if (j->value("type", protocol::Json()) == "hello") {
    adit::StatusOr<protocol::Hello> h = protocol::parseHello(*j);
    if (!h.ok()) return;
    if (!protocol::validRobotId(h->robot) || !(h->radius > 0.0) || h->radius > kMaxRobotRadius) std::abort();
    return;
  }
  adit::StatusOr<protocol::RobotFrame> f = protocol::parseRobotMessage(*j);
  if (!f.ok()) return;
  const RobotMessage& m = f->message;
  if (m.seq < 1 || m.seq > kMaxSeq || !std::isfinite(m.t) || !protocol::validRobotId(m.robot)) std::abort();
  if (m.pose) {
    const RobotMessage::Pose& p = *m.pose;
    for (double v : {p.x, p.y, p.z, p.vx, p.vy, p.vz})
      if (!std::isfinite(v)) std::abort();
  }
  // Both ends' one parser: what it accepted, written by the robot's toJson, reads back as itself.
  const auto write = [](const protocol::Body& b) { return std::visit([](const auto& m) { return toJson(m); }, b); };
  const std::string again = write(f->body);
  adit::StatusOr<protocol::Body> back = protocol::parseBody(protocol::Json::parse(again));
  if (!back.ok() || write(*back) != again) std::abort();
}

void operatorBody(const std::string& text) {
  adit::StatusOr<protocol::Json> j = protocol::parseObject(text);
  if (!j.ok()) return;
  adit::StatusOr<protocol::CommandRequest> c = protocol::parseCommandRequest(*j);
  if (!c.ok()) return;
  if (!protocol::validRobotId(c->robot)) std::abort();
  if (c->goal) finiteOrAbort(*c->goal, 1e308);
  if (c->velocity) finiteOrAbort(*c->velocity, 1e308);
}

void centreFrame(const std::string& text) {
  adit::StatusOr<ReceivedCommand> c = parseCommand(text);
  if (!c.ok()) return;
  if (c->id < 1 || c->id > kMaxSeq) std::abort();
  if (c->goal) finiteOrAbort(*c->goal, kMaxCoordinate);
  if (c->velocity) {
    finiteOrAbort(*c->velocity, kMaxManualSpeed);
    if (c->velocity->norm() > kMaxManualSpeed) std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  switch (data[0] % 3) {
    case 0: robotFrame(text); break;
    case 1: operatorBody(text); break;
    default: centreFrame(text); break;
  }
  return 0;
}
