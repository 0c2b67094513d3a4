// The daemon's status file written off the frame loop's thread (docs/daemon.md, "Status file"):
// the loop hands each status window's text to post() -- a move into a one-slot mailbox, the
// latest window wins -- and a thread of its own writes it with write_file_atomically (temporary
// file, fsync, rename), so a slow, stalled or full disk never costs the loop a vsync. A window
// posted while the previous one is still being written replaces any window not yet written (it is
// counted as dropped). A file that cannot be written is logged once when writing starts failing
// and once when it works again; the loop never waits for either.
// Cost on the loop: a lock and a string move per window. The write and its fsync on the writer.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>

#include "hmdnode/core/result.hpp"

namespace hmdnode {

class StatusWriter {
  public:
    // Writes `bytes` to `path`; write_file_atomically by default (tests pass their own).
    using WriteFn = std::function<Status(const std::filesystem::path&, std::string_view)>;

    struct Counts {
        uint64_t posted = 0;
        uint64_t written = 0;  // writes that succeeded
        uint64_t failed = 0;   // writes that failed
        uint64_t dropped = 0;  // windows replaced by a newer one before they were written
    };

    // `retry_every_s` only words the failure message ("retried every N s").
    explicit StatusWriter(double retry_every_s, WriteFn write = {});
    // Writes the window still waiting (if any), then joins the writer thread.
    ~StatusWriter();
    StatusWriter(const StatusWriter&) = delete;
    StatusWriter& operator=(const StatusWriter&) = delete;

    // Hands a window to the writer; never waits for a write.
    void post(std::filesystem::path path, std::string text);
    // Waits until every window posted so far is written or failed (or dropped).
    void flush();
    Counts counts() const;

  private:
    void run();

    double retry_every_s_;
    WriteFn write_;
    mutable std::mutex mu_;
    std::condition_variable wake_, idle_;
    std::optional<std::pair<std::filesystem::path, std::string>> pending_;
    bool writing_ = false;
    bool stop_ = false;
    bool failing_ = false;  // the last write failed (said once); the writer thread's only
    Counts counts_;
    std::thread thread_;  // note: last, so it starts after every member it reads
};

}  // namespace hmdnode
