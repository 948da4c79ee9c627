// SPDX-License-Identifier: BSD-3-Clause
// The console's writer thread: group-commits robot messages, then hands the outcome back to
// the I/O thread (acks, errors, viewers, command results).
#include "ws_session.hpp"

namespace adit::console {

void Server::Impl::startWriter() {
  writer = std::thread([this] { writeLoop(); });
}

void Server::Impl::stopWriter() {
  {
    std::lock_guard<std::mutex> lock(queue_mutex);
    stopping = true;
  }
  queue_cv.notify_one();
  if (writer.joinable()) writer.join();
}

// The writer thread: takes everything queued, stores the new messages in one transaction and
// re-checks possible resends one by one, then hands the outcome to the I/O thread.
void Server::Impl::writeLoop() {
  for (;;) {
    std::vector<PendingMessage> batch;
    {
      std::unique_lock<std::mutex> lock(queue_mutex);
      queue_cv.wait(lock, [this] { return stopping || !queue.empty(); });
      if (stopping) return;  // queued but unstored: never acknowledged, the robots resend
      batch.swap(queue);
    }
    std::vector<RobotMessage> fresh;
    for (const PendingMessage& p : batch)
      if (p.mode == PendingMessage::Mode::kBatch) fresh.push_back(p.message);
    Status status = Status::okStatus();
    if (!fresh.empty()) {
      StatusOr<std::size_t> n = store->appendMessages(fresh);
      if (!n.ok()) {
        status = n.status();
      } else if (*n != fresh.size()) {  // another centre on the same database stored some
        logLine("database: " + std::to_string(fresh.size() - *n) + " of a batch were stored already");
      }
    }
    for (PendingMessage& p : batch) {
      p.fresh = p.mode == PendingMessage::Mode::kBatch && status.ok();
      if (p.mode != PendingMessage::Mode::kExact || !status.ok()) continue;
      StatusOr<bool> one = store->appendMessage(p.message);
      if (!one.ok()) {
        status = one.status();
        continue;
      }
      p.fresh = *one;
    }
    net::post(ioc, [this, done = std::move(batch), status]() mutable { finish(std::move(done), status); });
  }
}

// On the I/O thread: ack what is stored (an error for what is not: the robot keeps it and
// resends), push the new messages to the viewers, record command results.
void Server::Impl::finish(std::vector<PendingMessage> done, const Status& status) {
  if (!status.ok()) logLine("database: " + status.message());
  for (PendingMessage& p : done) {
    const RobotMessage& m = p.message;
    if (p.mode == PendingMessage::Mode::kBatch) in_flight.erase({m.robot, m.seq});
    auto session = p.session.lock();
    if (!status.ok()) {
      if (session) session->send(errorJson("database: " + status.message(), m.seq));
      continue;
    }
    if (session) session->send(Json{{"type", "ack"}, {"seq", m.seq}});
    if (!p.fresh) continue;
    RobotCache& c = cache[m.robot];
    c.stored_seq = std::max(c.stored_seq, m.seq);
    Json& stored = p.json;
    stored["received_at"] = m.received_at;
    if (m.type == "telemetry") c.telemetry = stored;
    if (m.type == "plan") c.plan = stored;
    if (m.type == "obstacles") c.tracks = stored.value("tracks", Json::array());
    broadcast(stored, m.type == "telemetry");
    if (const auto* tm = std::get_if<Telemetry>(&p.body)) onTelemetryStored(m.robot, *tm);
    if (p.command) {
      // A robot answers a command it got again with its stored result: never step back
      // (executed stays executed when an `accepted` repeat arrives).
      const auto& r = std::get<CommandResult>(p.body);
      const CommandStatus result = *parseCommandStatus(r.result);
      Command now = *p.command;  // its state when the result was queued; re-read, results may batch
      if (auto current = store->command(now.command_id); current.ok() && *current) now = **current;
      if (static_cast<int>(result) >= static_cast<int>(now.status)) setCommandStatus(now, result, r.reason);
    }
  }
}

}  // namespace adit::console
