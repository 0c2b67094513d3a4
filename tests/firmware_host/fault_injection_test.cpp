// Faults from the world (the service's fault-injection targets): the status directory unwritable
// under the daemon, the scene file replaced under the running daemon, and SIGTERM in the middle of
// `hmdnode bake`, `lod` and `record` (README "Commands": the command ends by the signal, leaving no
// output and no temporary file). No test waits for a time: each waits for an event (a file, CPU
// time spent inside the command) with a bound only against a hang.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>
#include "firmware_host/command_run.hpp"

namespace fs = std::filesystem;

namespace {

const std::string kScene = HMDNODE_DEMO_SCENE;
const std::string kTrace = HMDNODE_SOURCE_DIR "/data/traces/corbillon2018_user1.csv";

std::string read_text(const fs::path& p) {
    std::ifstream in(p);
    return std::string((std::istreambuf_iterator<char>(in)), {});
}

size_t count(const std::string& text, const std::string& what) {
    size_t n = 0;
    for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
    return n;
}

// The process's CPU time in clock ticks (utime + stime, /proc/PID/stat); -1 when it is gone or a
// zombie.
long cpu_ticks(pid_t pid) {
    std::istringstream in(read_text("/proc/" + std::to_string(pid) + "/stat"));
    std::string field;
    std::vector<std::string> f;
    // note: field 2 (comm) is in parentheses; the program names here have no spaces.
    while (in >> field) f.push_back(field);
    if (f.size() < 20 || f[2] == "Z") return -1;
    return std::stol(f[13]) + std::stol(f[14]);
}
// Polls `ready` every 10 ms until it holds (true) or the process ended or 120 s passed (false).
bool wait_for(pid_t pid, const std::function<bool()>& ready) {
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(120);
    while (std::chrono::steady_clock::now() < give_up) {
        if (cpu_ticks(pid) < 0) return false;
        if (ready()) return true;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
}

int wait_status(pid_t pid) {
    int st = 0;
    ::waitpid(pid, &st, 0);
    return st;
}

std::vector<std::string> files_in(const fs::path& dir) {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename());
    return names;
}

// Runs a tool command into the empty directory `out_dir`, sends SIGTERM once `in_the_middle`
// holds, and checks: it ended by SIGTERM, and `out_dir` holds nothing (no output, no temporary).
void expect_sigterm_leaves_nothing(const std::vector<std::string>& args, const fs::path& out_dir,
                                   const std::function<bool(pid_t)>& in_the_middle) {
    const fs::path log = out_dir.parent_path() / (out_dir.filename().string() + ".log");
    const pid_t pid = hmdnode::test::spawn(args, log);
    ASSERT_GT(pid, 0);
    const bool reached = wait_for(pid, [&] { return in_the_middle(pid); });
    ::kill(pid, SIGTERM);
    const int st = wait_status(pid);
    ASSERT_TRUE(reached) << "the command ended before the middle of its work: " << read_text(log);
    ASSERT_TRUE(WIFSIGNALED(st)) << "exit status " << WEXITSTATUS(st) << ": " << read_text(log);
    EXPECT_EQ(WTERMSIG(st), SIGTERM);
    EXPECT_TRUE(files_in(out_dir).empty())
        << "left behind: " << nlohmann::json(files_in(out_dir)).dump() << "\n"
        << read_text(log);
}

nlohmann::json sim_config(const fs::path& scene, const fs::path& status) {
    return {{"scene", scene.string()},
            {"clock", "sim"},
            {"tracker", {{"backend", "trace"}, {"trace", kTrace}, {"loop", true}}},
            {"display", {{"eye_width", 32}, {"eye_height", 32}}},
            {"status", {{"path", status.string()}, {"every_s", 0.05}}},
            {"control", {{"path", ""}}}};
}

// The daemon on `cfg` for 240 frames (about 53 status windows): it runs them all, exits 0, and
// says once why the status file cannot be written.
// `prefix` runs before the daemon in the same shell (limits, traps).
void expect_status_failure_said_once(const fs::path& dir, const nlohmann::json& cfg,
                                     const std::string& prefix = "") {
    std::ofstream(dir / "hmdnoded.json") << cfg.dump(1);
    const hmdnode::test::CommandRun r =
        hmdnode::test::run(prefix + "exec " + std::string(HMDNODE_DAEMON) + " --config " +
                           (dir / "hmdnoded.json").string() + " --max-frames 240");
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("stopped after 240 frames (0 failed)"), std::string::npos) << r.output;
    EXPECT_EQ(count(r.output, "status file:"), 1u) << r.output;
    EXPECT_NE(r.output.find("the loop goes on"), std::string::npos) << r.output;
}

}  // namespace

TEST(FaultInjection, StatusDirectoryReadOnlyKeepsTheLoopAndIsSaidOnce) {
    if (geteuid() == 0)
        GTEST_SKIP() << "root writes into a mode-0555 directory; the missing-directory test below "
                        "covers the same failure of the write";
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_fault_status_ro");
    fs::create_directories(dir / "status");
    fs::permissions(dir / "status", fs::perms::owner_read | fs::perms::owner_exec);
    expect_status_failure_said_once(dir, sim_config(kScene, dir / "status" / "status.json"));
    fs::permissions(dir / "status", fs::perms::owner_all);
    EXPECT_FALSE(fs::exists(dir / "status" / "status.json"));
}

TEST(FaultInjection, StatusDirectoryMissingKeepsTheLoopAndIsSaidOnce) {
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_fault_status_gone");
    // note: a regular file where the directory should be: no user, root included, can write there.
    std::ofstream(dir / "status") << "not a directory";
    expect_status_failure_said_once(dir, sim_config(kScene, dir / "status" / "status.json"));
}

TEST(FaultInjection, StatusFileSystemFullKeepsTheLoopAndIsSaidOnce) {
    // A full file system, for every user (root included): RLIMIT_FSIZE 0 makes every write of a
    // byte to a file fail with EFBIG, as ENOSPC would; SIGXFSZ ignored (inherited across exec) so
    // the write fails instead of killing the process.
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_fault_status_full");
    expect_status_failure_said_once(dir, sim_config(kScene, dir / "status.json"),
                                    "trap '' XFSZ; ulimit -f 0; ");
    EXPECT_FALSE(fs::exists(dir / "status.json"));
    for (const auto& e : fs::directory_iterator(dir))
        EXPECT_EQ(e.path().filename(), "hmdnoded.json") << "a partial file was left: " << e.path();
}

TEST(FaultInjection, SceneFileReplacedUnderTheRunningDaemonChangesNothing) {
    // The daemon reads the scene at start and again only when asked (docs/daemon.md): replacing
    // the file with one that does not load and a reload (SIGHUP) keep the running scene, and
    // removing it afterwards changes nothing; the loop goes on as it was.
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_fault_scene_replaced");
    fs::copy_file(kScene, dir / "scene.glb");
    std::ofstream(dir / "hmdnoded.json")
        << sim_config(dir / "scene.glb", dir / "status.json").dump(1);
    const pid_t pid = hmdnode::test::spawn(
        {HMDNODE_DAEMON, "--config", (dir / "hmdnoded.json").string()}, dir / "log");
    ASSERT_GT(pid, 0);
    auto frames = [&]() -> int64_t {
        const nlohmann::json s =
            nlohmann::json::parse(read_text(dir / "status.json"), nullptr, false);
        return s.is_object() && s.contains("frames") ? s["frames"].get<int64_t>() : -1;
    };
    // Running: a status file with frames.
    ASSERT_TRUE(wait_for(pid, [&] { return frames() > 0; })) << read_text(dir / "log");
    std::ofstream(dir / "scene.glb", std::ios::trunc) << "glTF but not really";
    ::kill(pid, SIGHUP);
    const int64_t at_replace = frames();
    ASSERT_TRUE(wait_for(pid, [&] {
        return read_text(dir / "log").find("reload: applied") != std::string::npos;
    })) << read_text(dir / "log");
    fs::remove(dir / "scene.glb");
    // Frames keep coming after the replacement, the reload and the removal.
    const int64_t at_remove = frames();
    EXPECT_TRUE(wait_for(pid, [&] { return frames() > at_remove + 90; })) << read_text(dir / "log");
    ::kill(pid, SIGTERM);
    const int st = wait_status(pid);
    const std::string log = read_text(dir / "log");
    ASSERT_TRUE(WIFEXITED(st)) << log;
    EXPECT_EQ(WEXITSTATUS(st), 0) << log;
    EXPECT_GT(at_remove, 0);
    EXPECT_GE(at_remove, at_replace);
    EXPECT_EQ(log.find("needs a restart"), std::string::npos)
        << "the config did not change: " << log;
    EXPECT_EQ(log.find("failed:"), std::string::npos) << "no frame failed: " << log;
    EXPECT_NE(log.find("keeping the running scene " + (dir / "scene.glb").string()),
              std::string::npos)
        << log;
    const nlohmann::json s = nlohmann::json::parse(read_text(dir / "status.json"));
    EXPECT_EQ(s["errors"].get<int>(), 0) << s;
}

TEST(FaultInjection, SigtermInTheMiddleOfBakeLeavesNoOutput) {
    const fs::path root = hmdnode::test::fresh_temp_dir("hmdnode_fault_sigterm_bake");
    fs::create_directories(root / "out");
    // Half a second of CPU into a bake that takes many seconds.
    expect_sigterm_leaves_nothing(
        {HMDNODE_TOOL, "bake", "--in", kScene, "--out", (root / "out" / "baked.glb").string(),
         "--samples", "4096", "--report", (root / "out" / "report.json").string()},
        root / "out", [](pid_t pid) { return cpu_ticks(pid) >= sysconf(_SC_CLK_TCK) / 2; });
}

TEST(FaultInjection, SigtermInTheMiddleOfLodLeavesNoOutput) {
    const fs::path root = hmdnode::test::fresh_temp_dir("hmdnode_fault_sigterm_lod");
    fs::create_directories(root / "out");
    expect_sigterm_leaves_nothing(
        {HMDNODE_TOOL, "lod", "--in", HMDNODE_SOURCE_DIR "/data/meshes/stanford-bunny.obj", "--out",
         (root / "out" / "bunny.glb").string(), "--ratios", "0.5,0.2,0.1,0.05,0.02,0.01",
         "--samples", "4000000", "--report", (root / "out" / "report.json").string(),
         "--progressive", (root / "out" / "bunny.hmpm").string()},
        root / "out", [](pid_t pid) { return cpu_ticks(pid) >= sysconf(_SC_CLK_TCK) / 2; });
}

TEST(FaultInjection, SigtermInTheMiddleOfRecordLeavesNoOutput) {
    const fs::path root = hmdnode::test::fresh_temp_dir("hmdnode_fault_sigterm_record");
    fs::create_directories(root / "out");
    // Recording for an hour on the real clock: 20 ms of CPU is past the start (the options, the
    // simulated device opened), inside the recording loop.
    expect_sigterm_leaves_nothing(
        {HMDNODE_TOOL, "record", "--device", "1209:0001", "--backend", "sim", "--duration", "3600",
         "--out", (root / "out" / "t.csv").string(), "--capture",
         (root / "out" / "t.pcap").string()},
        root / "out", [](pid_t pid) { return cpu_ticks(pid) >= sysconf(_SC_CLK_TCK) / 50; });
}
