// SPDX-License-Identifier: BSD-3-Clause
// readFile (bounded, regular files only) and writeFileAtomically: temporary file + rename for regular files, written through for character
// devices and FIFOs, symlinks resolved to their target, and the temporary file removed when the
// process is interrupted (SIGINT/SIGTERM) in the middle of a write.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <climits>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <random>

#include "adit/map/file_io.hpp"

namespace adit::map {

namespace fs = std::filesystem;

namespace {

// ---- Temporary files removed by a signal handler ---------------------------------------------
// The handler may only use async-signal-safe calls, so the paths live in fixed buffers guarded by
// lock-free atomics: a slot is claimed (1), filled, then armed (2); the handler unlinks armed
// slots, puts the previous disposition back and re-raises, so the process still dies of the
// signal (or the application's own handler runs).
constexpr int kSlots = 32;
constexpr int kFree = 0, kClaimed = 1, kArmed = 2;
struct TempSlot {
  std::atomic<int> state{kFree};
  char path[PATH_MAX];
};
TempSlot g_slots[kSlots];
static_assert(std::atomic<int>::is_always_lock_free, "the signal handler needs lock-free atomics");

constexpr int kSignals[] = {SIGINT, SIGTERM, SIGHUP};
struct sigaction g_previous[sizeof(kSignals) / sizeof(kSignals[0])];
bool g_installed[sizeof(kSignals) / sizeof(kSignals[0])];
std::mutex g_handler_mutex;
int g_handler_users = 0;

extern "C" void removeTempFilesAndReraise(int sig) {
  const int saved_errno = errno;
  for (TempSlot& slot : g_slots)
    if (slot.state.load() == kArmed) ::unlink(slot.path);
  for (std::size_t i = 0; i < sizeof(kSignals) / sizeof(kSignals[0]); ++i)
    if (kSignals[i] == sig) ::sigaction(sig, &g_previous[i], nullptr);
  errno = saved_errno;
  ::raise(sig);  // blocked until this handler returns, then delivered to the previous disposition
}

// Registers a temporary path for the handler while it lives; installs the handler for the first
// writer and restores the previous ones after the last. A signal the process ignores stays ignored.
class TempFileGuard {
 public:
  explicit TempFileGuard(const std::string& path) {
    if (path.size() >= PATH_MAX) return;
    for (TempSlot& s : g_slots) {
      int expected = kFree;
      if (s.state.compare_exchange_strong(expected, kClaimed)) {
        std::memcpy(s.path, path.c_str(), path.size() + 1);
        s.state.store(kArmed);
        slot_ = &s;
        break;
      }
    }
    std::lock_guard<std::mutex> lock(g_handler_mutex);
    if (g_handler_users++ > 0) return;
    for (std::size_t i = 0; i < sizeof(kSignals) / sizeof(kSignals[0]); ++i) {
      g_installed[i] = false;
      struct sigaction current {};
      if (::sigaction(kSignals[i], nullptr, &current) != 0 || current.sa_handler == SIG_IGN) continue;
      g_previous[i] = current;
      struct sigaction ours {};
      ours.sa_handler = removeTempFilesAndReraise;
      sigemptyset(&ours.sa_mask);
      g_installed[i] = ::sigaction(kSignals[i], &ours, nullptr) == 0;
    }
  }
  ~TempFileGuard() {
    if (slot_) slot_->state.store(kFree);
    std::lock_guard<std::mutex> lock(g_handler_mutex);
    if (--g_handler_users > 0) return;
    for (std::size_t i = 0; i < sizeof(kSignals) / sizeof(kSignals[0]); ++i) {
      if (!g_installed[i]) continue;
      // Put the previous handler back only if nobody replaced ours in the meantime.
      struct sigaction current {};
      if (::sigaction(kSignals[i], nullptr, &current) == 0 && current.sa_handler == removeTempFilesAndReraise)
        ::sigaction(kSignals[i], &g_previous[i], nullptr);
      g_installed[i] = false;
    }
  }
  TempFileGuard(const TempFileGuard&) = delete;
  TempFileGuard& operator=(const TempFileGuard&) = delete;

 private:
  TempSlot* slot_ = nullptr;
};

// ---- Destinations --------------------------------------------------------------------------

// Follows a chain of symbolic links to the path they finally name (which may not exist yet: a
// dangling link is written through, creating its target).
StatusOr<fs::path> resolveSymlinks(const std::string& path) {
  fs::path p(path);
  for (int hops = 0;; ++hops) {
    std::error_code ec;
    const fs::file_status st = fs::symlink_status(p, ec);
    if (!fs::is_symlink(st)) return p;
    if (hops >= 40) return invalidArgument(path + ": too many levels of symbolic links");
    const fs::path link = fs::read_symlink(p, ec);
    if (ec) return invalidArgument(path + ": cannot read the symbolic link '" + p.string() + "': " + ec.message());
    p = link.is_absolute() ? link : (p.has_parent_path() ? p.parent_path() : fs::path(".")) / link;
  }
}

// Runs the writer on `out`, turning a false return, an exception or a failed stream into a reason.
bool runWriter(const std::function<bool(std::ostream&)>& write, std::ofstream& out, std::string* why) {
  try {
    const bool wrote = write(out);
    out.flush();
    const bool stream_ok = out.good();
    out.close();
    if (!wrote) *why = "the writer reported a failure";
    else if (!stream_ok || out.fail()) *why = std::string("write failed (disk full or I/O error?)");
    return wrote && stream_ok && !out.fail();
  } catch (const std::exception& e) {
    *why = std::string("the writer threw: ") + e.what();
  } catch (...) {
    *why = "the writer threw an exception";
  }
  return false;
}

// A character device or FIFO is written in place: replacing it with a regular file would destroy
// it (and the reader of a FIFO would never see the data). Such a write cannot be atomic.
Status writeThrough(const std::string& path, const std::function<bool(std::ostream&)>& write) {
  std::ofstream out(path, std::ios::binary | std::ios::out);
  if (!out) return invalidArgument(path + ": cannot open for writing: " + std::strerror(errno));
  std::string why;
  if (!runWriter(write, out, &why)) return internalError(path + ": " + why);
  return {};
}

}  // namespace

Status writeFileAtomically(const std::string& path, const std::function<bool(std::ostream&)>& write) {
  // A device or pipe is asked of the kernel first: /dev/stdout on a pipe links to
  // "/proc/self/fd/pipe:[N]", which is no path to resolve, but opening /dev/stdout works.
  {
    std::error_code ec;
    const fs::file_type type = fs::status(path, ec).type();
    if (!ec && (type == fs::file_type::character || type == fs::file_type::fifo)) return writeThrough(path, write);
  }
  StatusOr<fs::path> resolved = resolveSymlinks(path);
  if (!resolved.ok()) return resolved.status();
  const fs::path target = *resolved;
  const std::string shown = target.string() == path ? path : path + " (-> " + target.string() + ")";
  std::error_code ec;
  const fs::file_status st = fs::status(target, ec);
  switch (st.type()) {
    case fs::file_type::not_found:
    case fs::file_type::regular:
      break;
    case fs::file_type::directory:
      return invalidArgument(shown + ": is a directory");
    case fs::file_type::block:
      return invalidArgument(shown + ": is a block device; adit does not write to block devices");
    case fs::file_type::socket:
      return invalidArgument(shown + ": is a socket, not a file");
    default:
      if (ec) return invalidArgument(shown + ": cannot access: " + ec.message());
      return invalidArgument(shown + ": is not a regular file");
  }
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  if (!fs::is_directory(dir, ec)) return notFound(shown + ": directory '" + dir.string() + "' does not exist");
  std::random_device rd;
  const fs::path tmp = dir / ("." + target.filename().string() + ".tmp" + std::to_string(::getpid()) + "_" +
                              std::to_string(rd() % 1000000));
  // Registered before the file exists, so that no moment leaves it behind on Ctrl-C.
  TempFileGuard guard(tmp.string());
  std::string why;
  bool ok = false;
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out)
      return invalidArgument(shown + ": cannot create a file in '" + dir.string() + "': " + std::strerror(errno));
    ok = runWriter(write, out, &why);
  }
  // A replaced file keeps its permission bits (a map made read-only for others stays so).
  if (ok && st.type() == fs::file_type::regular) {
    struct stat old {};
    if (::stat(target.c_str(), &old) == 0) ::chmod(tmp.c_str(), old.st_mode & 07777);
  }
  if (ok) {
    // Make the data durable before the rename makes it visible, so a crash cannot leave an empty
    // file under the target's name.
    const int fd = ::open(tmp.c_str(), O_RDONLY);
    if (fd < 0 || ::fsync(fd) != 0) { ok = false; why = std::string("fsync failed: ") + std::strerror(errno); }
    if (fd >= 0) ::close(fd);
  }
  if (ok) {
    fs::rename(tmp, target, ec);
    if (ec) { ok = false; why = "rename failed: " + ec.message(); }
  }
  if (!ok) {
    fs::remove(tmp, ec);
    return internalError(shown + ": " + why + "; nothing was written");
  }
  return {};
}

StatusOr<std::string> readFile(const std::string& path, std::size_t max_bytes) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (st.type() == fs::file_type::not_found) return notFound(path + ": no such file");
  if (ec) return notFound(path + ": cannot access: " + ec.message());
  if (fs::is_directory(st)) return invalidArgument(path + ": is a directory, not a file");
  // Opening a FIFO blocks until someone writes to it, and devices have no size: refuse both.
  if (!fs::is_regular_file(st))
    return invalidArgument(path + ": not a regular file (a device, FIFO or socket)");
  std::ifstream in(path, std::ios::binary);
  if (!in) return notFound(path + ": cannot open: " + std::strerror(errno));
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0) return dataLoss(path + ": cannot determine the file size");
  if (std::uint64_t(size) > max_bytes)
    return invalidArgument(path + ": file is " + std::to_string(size) + " bytes, above the limit of " +
                           std::to_string(max_bytes));
  in.seekg(0);
  std::string bytes(std::size_t(size), '\0');
  if (size > 0 && !in.read(bytes.data(), size)) return dataLoss(path + ": read error");
  return bytes;
}

}  // namespace adit::map
