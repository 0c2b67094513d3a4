// The status file's writer thread (hmdnode/firmware_host/status_writer.hpp).
#include "hmdnode/firmware_host/status_writer.hpp"

#include <pthread.h>
#include <signal.h>

#include <spdlog/spdlog.h>

#include "hmdnode/core/atomic_file.hpp"

namespace hmdnode {

StatusWriter::StatusWriter(double retry_every_s, WriteFn write)
    : retry_every_s_(retry_every_s),
      write_(write ? std::move(write) : WriteFn(write_file_atomically)) {
    // The termination signals stay with the frame loop's thread (its handlers set flags it reads
    // between frames): the writer is started with them blocked and keeps that mask.
    sigset_t block, old;
    sigemptyset(&block);
    for (int sig : {SIGTERM, SIGINT, SIGHUP}) sigaddset(&block, sig);
    pthread_sigmask(SIG_BLOCK, &block, &old);
    thread_ = std::thread([this] { run(); });
    pthread_sigmask(SIG_SETMASK, &old, nullptr);
}

StatusWriter::~StatusWriter() {
    {
        std::lock_guard lock(mu_);
        stop_ = true;
    }
    wake_.notify_all();
    thread_.join();
}

void StatusWriter::post(std::filesystem::path path, std::string text) {
    {
        std::lock_guard lock(mu_);
        ++counts_.posted;
        if (pending_) ++counts_.dropped;
        pending_.emplace(std::move(path), std::move(text));
    }
    wake_.notify_one();
}

void StatusWriter::flush() {
    std::unique_lock lock(mu_);
    idle_.wait(lock, [this] { return !pending_ && !writing_; });
}

StatusWriter::Counts StatusWriter::counts() const {
    std::lock_guard lock(mu_);
    return counts_;
}

void StatusWriter::run() {
    std::unique_lock lock(mu_);
    for (;;) {
        wake_.wait(lock, [this] { return stop_ || pending_; });
        if (!pending_) break;  // stopping, nothing left to write
        auto [path, text] = std::move(*pending_);
        pending_.reset();
        writing_ = true;
        lock.unlock();
        const Status st = write_(path, text);
        if (!st.ok() && !failing_)
            spdlog::warn("status file: {}; the loop goes on, retried every {} s",
                         st.error().message, retry_every_s_);
        else if (st.ok() && failing_)
            spdlog::info("status file: {} written again", path.string());
        failing_ = !st.ok();
        lock.lock();
        writing_ = false;
        ++(st.ok() ? counts_.written : counts_.failed);
        if (!pending_) idle_.notify_all();
    }
    idle_.notify_all();
}

}  // namespace hmdnode
