// The status file's writer thread (hmdnode/firmware_host/status_writer.hpp): what it writes, and
// that a write that stalls (a hung disk, a full one) never holds the thread that posts -- the
// frame loop. No test waits for a time: a stalled write is a write function blocked on a future
// until the test lets it go.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <future>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

#include "firmware_host/command_run.hpp"
#include "hmdnode/firmware_host/status_writer.hpp"

namespace fs = std::filesystem;
using hmdnode::Status;
using hmdnode::StatusWriter;

namespace {

std::string read_all(const fs::path& p) {
    std::ifstream f(p);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

}  // namespace

TEST(StatusWriter, WritesEachWindowToTheFileAtomically) {
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_status_writer");
    StatusWriter w(1.0);
    w.post(dir / "status.json", "{\"frames\": 1}\n");
    w.flush();
    EXPECT_EQ(read_all(dir / "status.json"), "{\"frames\": 1}\n");
    w.post(dir / "status.json", "{\"frames\": 2}\n");
    w.flush();
    EXPECT_EQ(read_all(dir / "status.json"), "{\"frames\": 2}\n");
    const StatusWriter::Counts c = w.counts();
    EXPECT_EQ(c.posted, 2u);
    EXPECT_EQ(c.written, 2u);
    EXPECT_EQ(c.failed, 0u);
    // Nothing but the file: no temporary left beside it.
    size_t entries = 0;
    for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++entries;
    EXPECT_EQ(entries, 1u);
}

TEST(StatusWriter, AStalledWriteNeverHoldsThePosterAndTheLatestWindowWins) {
    std::promise<void> entered, release;
    std::shared_future<void> released = release.get_future().share();
    std::mutex mu;
    std::vector<std::string> writes;
    bool first = true;
    StatusWriter w(1.0, [&](const fs::path&, std::string_view text) -> Status {
        bool stall = false;
        {
            std::lock_guard lock(mu);
            writes.emplace_back(text);
            stall = first;
            first = false;
        }
        if (stall) {
            entered.set_value();
            released.wait();  // the disk hangs on the first write
        }
        return {};
    });
    w.post("status.json", "window 1");
    entered.get_future().wait();  // the writer is inside the stalled write of window 1
    // The loop goes on posting while the disk hangs: each post returns at once (were it to wait
    // for the write, this test would hang here), and only the newest window waits.
    for (int i = 2; i <= 50; ++i) w.post("status.json", "window " + std::to_string(i));
    StatusWriter::Counts c = w.counts();
    EXPECT_EQ(c.posted, 50u);
    EXPECT_EQ(c.written, 0u);
    EXPECT_EQ(c.dropped, 48u);  // windows 2..49, each replaced by the next
    release.set_value();
    w.flush();
    c = w.counts();
    EXPECT_EQ(c.written, 2u);
    std::lock_guard lock(mu);
    EXPECT_EQ(writes, (std::vector<std::string>{"window 1", "window 50"}));
}

TEST(StatusWriter, AFailingWriteIsCountedAndTheNextOneStillHappens) {
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_status_writer_fail");
    StatusWriter w(1.0);
    // note: a regular file where the directory should be: no user, root included, can write there.
    std::ofstream(dir / "gone") << "not a directory";
    w.post(dir / "gone" / "status.json", "lost");
    w.flush();
    w.post(dir / "status.json", "kept");
    w.flush();
    const StatusWriter::Counts c = w.counts();
    EXPECT_EQ(c.failed, 1u);
    EXPECT_EQ(c.written, 1u);
    EXPECT_EQ(read_all(dir / "status.json"), "kept");
}

TEST(StatusWriter, StoppingWritesTheWindowStillWaiting) {
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_status_writer_stop");
    {
        StatusWriter w(1.0);
        w.post(dir / "status.json", "last window");
    }  // no flush: the destructor writes it before the thread ends
    EXPECT_EQ(read_all(dir / "status.json"), "last window");
}
