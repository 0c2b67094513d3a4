// hmdnoded under systemd's notification protocol (docs/daemon.md, "Running as a service"): the
// test binds the unix datagram socket systemd would ($NOTIFY_SOCKET) and asks for a watchdog
// ($WATCHDOG_USEC). READY=1 comes once the first frame is presented, WATCHDOG=1 keeps coming while
// frames are presented, STOPPING=1 at the end; a tracker that never delivers gets no READY=1 and
// no WATCHDOG=1, only EXTEND_TIMEOUT_USEC= with a STATUS= that says what it waits for.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include "firmware_host/command_run.hpp"

extern char** environ;

namespace {

namespace fs = std::filesystem;

// A bound AF_UNIX datagram socket at `path`, as systemd's notify socket.
// A unix socket of `type` at `path`: bound (`bind`) or connected to it.
int unix_socket(int type, const fs::path& path, bool bind, bool* ok) {
    const int fd = ::socket(AF_UNIX, type | SOCK_CLOEXEC, 0);
    sockaddr_un a{};
    a.sun_family = AF_UNIX;
    std::strncpy(a.sun_path, path.c_str(), sizeof a.sun_path - 1);
    const sockaddr* sa = reinterpret_cast<sockaddr*>(&a);
    *ok = (bind ? ::bind(fd, sa, sizeof a) : ::connect(fd, sa, sizeof a)) == 0;
    return fd;
}

// What arrives on `fd` within timeout_ms ("" when nothing, or closed).
std::string receive_from(int fd, int timeout_ms) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, timeout_ms) <= 0) return {};
    char buf[4096];
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    return n > 0 ? std::string(buf, size_t(n)) : std::string();
}

// How long a wait for the daemon's next step gives up (a failure naming what never came): it
// waits on events and the daemon's progress, never on a time the step should take, so that a
// loaded machine or a sanitizer's slowdown (TSan: 5-15x) only makes it slower. Within CTest's
// TIMEOUT of 300 s, so the failure says what it waited for.
constexpr std::chrono::seconds kGiveUp{120};

// Whether `pid` has exited (it stays a zombie: wait_exit still collects its status).
bool has_exited(pid_t pid) {
    siginfo_t info{};
    return ::waitid(P_PID, id_t(pid), &info, WEXITED | WNOHANG | WNOWAIT) == 0 &&
           info.si_pid == pid;
}

class NotifySocket {
  public:
    explicit NotifySocket(const fs::path& path) {
        fd_ = unix_socket(SOCK_DGRAM, path, true, &bound_);
    }
    ~NotifySocket() { ::close(fd_); }
    bool bound() const { return bound_; }
    // The daemon whose messages these are: a wait ends when it exits.
    void watch(pid_t pid) { pid_ = pid; }
    // The next datagram within timeout_ms, or empty.
    std::string receive(int timeout_ms) { return receive_from(fd_, timeout_ms); }
    // The next datagram; empty once the daemon has exited and none is left, or after kGiveUp.
    std::string next() {
        const auto give_up = std::chrono::steady_clock::now() + kGiveUp;
        while (std::chrono::steady_clock::now() < give_up) {
            if (std::string m = receive_from(fd_, 200); !m.empty()) return m;
            if (pid_ > 0 && has_exited(pid_)) return receive_from(fd_, 0);
        }
        return {};
    }
    // Reads what has arrived. systemd reads every message at once; a test that did something
    // else meanwhile lets them queue (WATCHDOG=1 every 50 ms), and a full queue (10 datagrams,
    // net.unix.max_dgram_qlen) drops the daemon's next ones (it sends without waiting), so a
    // test drains it before it waits for a message that a signal causes.
    void drain() {
        while (!receive_from(fd_, 0).empty()) {
        }
    }
    // The next message that starts with `prefix` ("" when the daemon exited or after kGiveUp).
    std::string wait_for(const std::string& prefix) {
        for (std::string m; !(m = next()).empty();)
            if (m.rfind(prefix, 0) == 0) return m;
        return {};
    }
    std::string wait_ready() { return wait_for("READY=1"); }
    // Appends every datagram up to STOPPING=1 (or the daemon's exit).
    void receive_until_stopping(std::vector<std::string>* messages) {
        for (std::string m; !(m = next()).empty();) {
            messages->push_back(m);
            if (m == "STOPPING=1") break;
        }
    }

  private:
    int fd_ = -1;
    bool bound_ = false;
    pid_t pid_ = -1;
};

// Starts hmdnoded with the notify environment, its output to `log`.
pid_t spawn_daemon(const fs::path& config, const fs::path& sock, const std::string& max_frames,
                   const fs::path& log) {
    std::vector<std::string> env;
    for (char** e = environ; *e; ++e) env.emplace_back(*e);
    env.push_back("NOTIFY_SOCKET=" + sock.string());
    env.push_back("WATCHDOG_USEC=100000");  // a pet at most every 50 ms
    std::vector<char*> envp;
    for (std::string& e : env) envp.push_back(e.data());
    envp.push_back(nullptr);
    std::vector<std::string> args = {HMDNODE_DAEMON, "--config", config.string()};
    if (!max_frames.empty()) args.insert(args.end(), {"--max-frames", max_frames});
    return hmdnode::test::spawn(args, log, envp.data());
}

int wait_exit(pid_t pid) {
    int st = 0;
    ::waitpid(pid, &st, 0);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

std::string read_text(const fs::path& p) {
    std::ifstream in(p);
    return std::string((std::istreambuf_iterator<char>(in)), {});
}

bool starts_with(const std::string& s, const std::string& prefix) {
    return s.rfind(prefix, 0) == 0;
}

// The start-up calibration's progress: it extends systemd's start timeout while renders go on.
bool is_calibration_progress(const std::string& m) {
    return starts_with(m, "EXTEND_TIMEOUT_USEC=60000000\nSTATUS=calibrating the frame cost (");
}

// The bundled trace on the real clock (the watchdog is paced by wall time), 32x32 per eye.
nlohmann::json trace_config() {
    return {{"scene", HMDNODE_DEMO_SCENE},
            {"clock", "real"},
            {"tracker",
             {{"backend", "trace"},
              {"trace", HMDNODE_SOURCE_DIR "/data/traces/corbillon2018_user1.csv"}}},
            {"display", {{"eye_width", 32}, {"eye_height", 32}}}};
}

// Writes `cfg` to dir/hmdnoded.json and starts the daemon on it (notify socket dir/notify, output
// to dir/log).
pid_t start_daemon(const fs::path& dir, const nlohmann::json& cfg, const std::string& max_frames) {
    std::ofstream(dir / "hmdnoded.json") << cfg.dump(1);
    return spawn_daemon(dir / "hmdnoded.json", dir / "notify", max_frames, dir / "log");
}

}  // namespace

TEST(DaemonNotify, ReadyAfterTheFirstFrameThenTheWatchdogWhileFramesAreShown) {
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_daemon_notify_ready");
    NotifySocket sock(dir / "notify");
    ASSERT_TRUE(sock.bound());
    // 90 frames at 90 Hz: about a second.
    nlohmann::json cfg = trace_config();
    cfg["status"] = {{"every_s", 0.25}};
    const pid_t pid = start_daemon(dir, cfg, "90");
    ASSERT_GT(pid, 0);
    sock.watch(pid);
    std::vector<std::string> messages;
    sock.receive_until_stopping(&messages);
    const int code = wait_exit(pid);
    const std::string log = read_text(dir / "log");
    ASSERT_EQ(code, 0) << log;
    // Before READY=1 only the start-up calibration's progress (it extends the start timeout).
    size_t calibrating = 0;
    while (!messages.empty() && is_calibration_progress(messages.front())) {
        messages.erase(messages.begin());
        ++calibrating;
    }
    EXPECT_GE(calibrating, 1u) << log;
    ASSERT_FALSE(messages.empty()) << log;
    // READY=1 first (nothing before the first frame), with its STATUS=.
    EXPECT_EQ(messages.front(), "READY=1\nSTATUS=running: first frame presented") << log;
    EXPECT_LT(log.find("frame cost:"), log.find("ready: first frame presented")) << log;
    size_t pets = 0, statuses = 0;
    for (size_t i = 1; i < messages.size(); ++i) {
        pets += messages[i] == "WATCHDOG=1";
        if (starts_with(messages[i], "STATUS=frames ")) {
            ++statuses;
            EXPECT_NE(messages[i].find("on time"), std::string::npos) << messages[i];
            EXPECT_NE(messages[i].find("MTP p50"), std::string::npos) << messages[i];
        }
        EXPECT_EQ(messages[i].find("READY=1"), std::string::npos) << "READY=1 twice";
    }
    // About a second of frames, a pet at most every 50 ms: some, not one.
    EXPECT_GE(pets, 3u) << log;
    EXPECT_GE(statuses, 1u) << log;
    EXPECT_EQ(messages.back(), "STOPPING=1");
}

TEST(DaemonNotify, NoReadinessAndNoWatchdogWithoutFrames) {
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_daemon_notify_waiting");
    NotifySocket sock(dir / "notify");
    ASSERT_TRUE(sock.bound());
    // A device that is not plugged in: the loop keeps its pace, presenting nothing.
    const nlohmann::json cfg = {{"scene", HMDNODE_DEMO_SCENE},
                                {"clock", "real"},
                                {"tracker", {{"backend", "hidapi"}, {"device", "1209:fff7"}}},
                                {"display", {{"eye_width", 32}, {"eye_height", 32}}},
                                {"status", {{"every_s", 0.25}}}};
    const pid_t pid = start_daemon(dir, cfg, "");
    ASSERT_GT(pid, 0);
    sock.watch(pid);
    std::vector<std::string> messages;
    // The first EXTEND_TIMEOUT_USEC of the wait for the tracker (after the start-up calibration's
    // progress, however long a slow machine takes over it), then half a second more (ten
    // watchdog periods) of waiting.
    for (std::string m; !(m = sock.next()).empty();) {
        messages.push_back(m);
        if (starts_with(m, "EXTEND_TIMEOUT_USEC=") && !is_calibration_progress(m)) break;
    }
    // note: STATUS= keeps coming every window, so the half second is counted, not waited for.
    const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(500);
    while (std::chrono::steady_clock::now() < until)
        if (std::string m = sock.receive(50); !m.empty()) messages.push_back(m);
    ::kill(pid, SIGTERM);
    sock.receive_until_stopping(&messages);
    const int code = wait_exit(pid);
    const std::string log = read_text(dir / "log");
    EXPECT_EQ(code, 0) << log;
    while (!messages.empty() && is_calibration_progress(messages.front()))
        messages.erase(messages.begin());
    ASSERT_FALSE(messages.empty()) << log;
    EXPECT_TRUE(starts_with(messages.front(),
                            "EXTEND_TIMEOUT_USEC=15000000\nSTATUS=waiting for tracker hidapi"))
        << messages.front();
    for (const std::string& m : messages) {
        EXPECT_EQ(m.find("READY=1"), std::string::npos) << m;
        EXPECT_NE(m, "WATCHDOG=1");
    }
    EXPECT_EQ(messages.back(), "STOPPING=1");
}

// realtime_priority raises the frame loop's thread alone: the renderer's worker threads (Mesa's
// llvmpipe-N, created before it) and every other thread keep the default policy. Skipped where
// the priority is refused (no CAP_SYS_NICE and no RLIMIT_RTPRIO).
TEST(DaemonNotify, SigtermDuringTheStartUpCalibrationStopsItThereWithStatusZero) {
    // Large eyes make the calibration's ~50 renders take seconds (more under a sanitizer); the
    // signal goes once the first progress message says it has begun.
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_daemon_notify_calibration");
    NotifySocket sock(dir / "notify");
    ASSERT_TRUE(sock.bound());
    nlohmann::json cfg = trace_config();
    cfg["display"] = {{"eye_width", 1440}, {"eye_height", 1600}};
    const pid_t pid = start_daemon(dir, cfg, "");
    ASSERT_GT(pid, 0);
    std::vector<std::string> messages;
    for (std::string m; !(m = sock.receive(60000)).empty();) {
        messages.push_back(m);
        if (is_calibration_progress(m)) break;
    }
    ::kill(pid, SIGTERM);
    const int code = wait_exit(pid);
    const std::string log = read_text(dir / "log");
    ASSERT_FALSE(messages.empty()) << log;
    EXPECT_TRUE(is_calibration_progress(messages.back())) << messages.back();
    EXPECT_EQ(code, 0) << log;
    EXPECT_NE(log.find("stopped during the start-up calibration"), std::string::npos) << log;
    EXPECT_EQ(log.find("frame cost:"), std::string::npos) << "the calibration ran to its end\n"
                                                          << log;
    for (std::string m; !(m = sock.receive(100)).empty();) messages.push_back(m);
    for (const std::string& m : messages) EXPECT_EQ(m.find("READY=1"), std::string::npos) << m;
}

TEST(DaemonNotify, RealtimePriorityIsTheFrameLoopThreadsAlone) {
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_daemon_notify_rt");
    NotifySocket sock(dir / "notify");
    ASSERT_TRUE(sock.bound());
    nlohmann::json cfg = trace_config();
    cfg["realtime_priority"] = 1;
    const pid_t pid = start_daemon(dir, cfg, "");
    ASSERT_GT(pid, 0);
    sock.watch(pid);
    const std::string ready = sock.wait_ready();
    // The threads while the loop runs: (tid, name, policy).
    struct Thread {
        pid_t tid;
        std::string name;
        int policy;
    };
    std::vector<Thread> threads;
    for (const auto& t : fs::directory_iterator("/proc/" + std::to_string(pid) + "/task")) {
        const pid_t tid = pid_t(std::stol(t.path().filename().string()));
        std::string name = read_text(t.path() / "comm");
        while (!name.empty() && name.back() == '\n') name.pop_back();
        threads.push_back({tid, name, sched_getscheduler(tid) & ~SCHED_RESET_ON_FORK});
    }
    ::kill(pid, SIGTERM);
    const int code = wait_exit(pid);
    const std::string log = read_text(dir / "log");
    ASSERT_EQ(code, 0) << log;
    ASSERT_FALSE(ready.empty()) << log;
    if (log.find("refused") != std::string::npos) GTEST_SKIP() << "SCHED_FIFO refused here";
    ASSERT_NE(log.find("frame loop thread: SCHED_FIFO priority 1"), std::string::npos) << log;
    for (const Thread& t : threads) {
        if (t.tid == pid) {
            EXPECT_EQ(t.policy, SCHED_FIFO) << "the frame loop's thread";
        } else {
            EXPECT_NE(t.policy, SCHED_FIFO) << t.name << " (" << t.tid << ")";
        }
    }
    EXPECT_GE(threads.size(), 2u);  // lavapipe: llvmpipe-0, llvmpipe-1, ... beside the loop
}

namespace {

// A one-object scene (the tests' data): a swap shows in the status's object count.
const std::string kSmallScene = HMDNODE_SOURCE_DIR "/tests/data/gltf/triangle_data_uri.gltf";

// A raw client of the control socket: send bytes, read one reply line ("" when closed).
class RawClient {
  public:
    explicit RawClient(const fs::path& path) {
        fd_ = unix_socket(SOCK_STREAM, path, false, &connected_);
    }
    ~RawClient() { ::close(fd_); }
    bool connected() const { return connected_; }
    void send(const std::string& bytes) {
        (void)::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL);
    }
    // (The daemon answers between frames: kGiveUp bounds the wait.)
    std::string reply_line() {
        std::string in;
        while (in.find('\n') == std::string::npos) {
            const std::string more = receive_from(
                fd_, int(std::chrono::duration_cast<std::chrono::milliseconds>(kGiveUp).count()));
            if (more.empty()) return in;
            in += more;
        }
        return in.substr(0, in.find('\n'));
    }

  private:
    int fd_ = -1;
    bool connected_ = false;
};

// `hmdnode ctl`, waiting up to kGiveUp for the reply (the loop answers between frames; under a
// sanitizer on a loaded machine a frame that sets something up can take longer than the client's
// default 5 s).
hmdnode::test::CommandRun ctl(const fs::path& sock, const std::string& args) {
    return hmdnode::test::run(std::string(HMDNODE_TOOL) + " ctl --timeout " +
                              std::to_string(kGiveUp.count()) + " --socket " + sock.string() + " " +
                              args);
}

// The reply of `hmdnode ctl ARGS` as JSON; an empty object (the failure reported) when there is
// none.
nlohmann::json ctl_json(const fs::path& sock, const std::string& args) {
    const hmdnode::test::CommandRun r = ctl(sock, args);
    EXPECT_EQ(r.code, 0) << args << ": " << r.output;
    nlohmann::json j = nlohmann::json::parse(r.output, nullptr, false);
    return r.code == 0 && j.is_object() ? j : nlohmann::json::object();
}

// A daemon on trace_config() with a control socket (dir/control), started and ready; SIGTERM at
// the end unless the test stopped it.
class DaemonControl : public ::testing::Test {
  protected:
    void SetUp() override {
        dir = hmdnode::test::fresh_temp_dir(
            std::string("hmdnode_daemon_control_") +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
        notify = std::make_unique<NotifySocket>(dir / "notify");
        ASSERT_TRUE(notify->bound());
        sock = dir / "control";
        cfg = trace_config();
        cfg["control"] = {{"path", sock.string()}};
        pid = start_daemon(dir, cfg, "");
        ASSERT_GT(pid, 0);
        notify->watch(pid);
        ASSERT_FALSE(notify->wait_ready().empty()) << read_text(dir / "log");
    }
    void TearDown() override {
        if (pid > 0) stop();
    }
    int stop() {
        ::kill(pid, SIGTERM);
        const int code = wait_exit(pid);
        pid = -1;
        return code;
    }
    // Sends `sig` once the messages so far are read (notify->drain()), so that the ones it
    // causes (RELOADING=1, READY=1) find room in the queue.
    void signal_daemon(int sig) {
        notify->drain();
        ::kill(pid, sig);
    }
    // The status once no scene is loading (a load is read off the loop, then swapped in); the
    // daemon is asked again until then, for up to kGiveUp.
    nlohmann::json wait_scene_loaded() {
        const auto give_up = std::chrono::steady_clock::now() + kGiveUp;
        nlohmann::json st = ctl_json(sock, "status");
        while (!st.empty() && st.value("scene_loading", true) &&
               std::chrono::steady_clock::now() < give_up)
            st = ctl_json(sock, "status");
        EXPECT_FALSE(st.value("scene_loading", true)) << "the scene load never finished: " << st;
        return st;
    }
    // The loop presents frames: the status's count grows (asked again until it does, for up to
    // kGiveUp).
    void expect_frames_progress() {
        const auto give_up = std::chrono::steady_clock::now() + kGiveUp;
        const int before = ctl_json(sock, "status").value("frames", -1);
        int after = before;
        while (before >= 0 && after >= 0 && after <= before &&
               std::chrono::steady_clock::now() < give_up)
            after = ctl_json(sock, "status").value("frames", -1);
        EXPECT_GT(after, before) << "the frame loop stopped";
    }

    fs::path dir, sock;
    std::unique_ptr<NotifySocket> notify;
    nlohmann::json cfg;
    pid_t pid = -1;
};

}  // namespace

// The control socket: status, metrics, set, pause/resume through `hmdnode ctl`; a malformed
// command gets an error reply, an oversized one an error reply and the connection closed, and
// neither disturbs the frame loop, which goes on presenting frames.
TEST_F(DaemonControl, CommandsAnswerAndBadOnesDoNotDisturbTheLoop) {
    EXPECT_EQ(fs::status(sock).permissions() & fs::perms::all,
              fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read |
                  fs::perms::group_write);

    nlohmann::json st = ctl_json(sock, "status");
    EXPECT_TRUE(st["ready"].get<bool>()) << st;
    EXPECT_GE(st["frames"].get<int>(), 1) << st;
    const hmdnode::test::CommandRun m = ctl(sock, "metrics");
    EXPECT_EQ(m.code, 0) << m.output;
    for (const char* part :
         {"# TYPE hmdnode_frames_total counter\nhmdnode_frames_total ",
          "hmdnode_missed_vsyncs_total ", "hmdnode_motion_to_photon_seconds_bucket{le=\"+Inf\"} ",
          "hmdnode_render_seconds_count ", "hmdnode_triangles ",
          "# TYPE hmdnode_lod_pops_total counter\nhmdnode_lod_pops_total 0\n",
          "hmdnode_lod_transitions_total ", "hmdnode_lod_pops_per_minute 0\n"})
        EXPECT_NE(m.output.find(part), std::string::npos) << part << "\n" << m.output;

    // Bad commands: replies, and the loop goes on.
    RawClient bad(sock);
    ASSERT_TRUE(bad.connected());
    bad.send("{not json\n");
    EXPECT_NE(bad.reply_line().find("\"ok\":false"), std::string::npos);
    bad.send("{\"cmd\":\"no-such\"}\n");
    EXPECT_NE(bad.reply_line().find("unknown command"), std::string::npos);
    bad.send("{\"cmd\":\"set\",\"key\":5,\"value\":[]}\n");  // fields of the wrong type
    EXPECT_NE(bad.reply_line().find("\"ok\":false"), std::string::npos);
    bad.send(std::string(10000, 'x'));
    EXPECT_NE(bad.reply_line().find("longer than 4096 bytes"), std::string::npos);
    EXPECT_EQ(bad.reply_line(), "") << "the connection is closed";
    expect_frames_progress();

    // Settings and pause.
    EXPECT_EQ(ctl(sock, "set predict false").code, 0);
    EXPECT_FALSE(ctl_json(sock, "status")["predict"].get<bool>());
    EXPECT_EQ(ctl(sock, "set lod_tolerance_px -1").code, 1);
    EXPECT_EQ(ctl(sock, "pause").code, 0);
    EXPECT_TRUE(ctl_json(sock, "status")["paused"].get<bool>());
    EXPECT_EQ(ctl(sock, "resume").code, 0);
    EXPECT_FALSE(ctl_json(sock, "status")["paused"].get<bool>());

    EXPECT_EQ(stop(), 0) << read_text(dir / "log");
    EXPECT_FALSE(fs::exists(sock)) << "the socket is removed on exit";
    // No daemon: an error naming the socket, exit 1.
    const hmdnode::test::CommandRun gone = ctl(sock, "status");
    EXPECT_EQ(gone.code, 1);
    EXPECT_NE(gone.output.find(sock.string()), std::string::npos) << gone.output;
}

// SIGHUP at a frame boundary: a good new config's prediction, its offset, the LOD tolerance and
// bias apply without
// stopping the loop (RELOADING=1, then READY=1); a bad one is logged and the running config kept.
TEST_F(DaemonControl, HangupReloadsTheConfigAndABadOneKeepsTheRunningOne) {
    cfg["node"] = {
        {"predict", false}, {"lod_tolerance_px", 3.0}, {"prediction_ms", -7.5}, {"lod_bias", 1.5}};
    cfg["scene"] = HMDNODE_SOURCE_DIR "/no-such-scene.glb";  // needs a restart: named, not loaded
    std::ofstream(dir / "hmdnoded.json") << cfg.dump(1);
    signal_daemon(SIGHUP);
    EXPECT_EQ(notify->wait_for("RELOADING=1"), "RELOADING=1");
    EXPECT_EQ(notify->wait_ready(), "READY=1");
    nlohmann::json st = ctl_json(sock, "status");
    EXPECT_FALSE(st["predict"].get<bool>()) << st;
    EXPECT_DOUBLE_EQ(st["lod_tolerance_px"].get<double>(), 3.0) << st;
    EXPECT_DOUBLE_EQ(st["prediction_ms"].get<double>(), -7.5) << st;
    EXPECT_DOUBLE_EQ(st["lod_bias"].get<double>(), 1.5) << st;
    // The scene is read again off the loop; one that cannot be read keeps the running one.
    st = wait_scene_loaded();
    EXPECT_EQ(st["scene"], HMDNODE_DEMO_SCENE) << st;
    EXPECT_NE(st["scene_error"].get<std::string>().find("no-such-scene.glb"), std::string::npos)
        << st;
    EXPECT_NE(read_text(dir / "log").find("keeping the running scene"), std::string::npos)
        << read_text(dir / "log");
    expect_frames_progress();

    // A good new scene is swapped in at a frame boundary, the loop going on.
    cfg["scene"] = kSmallScene;
    std::ofstream(dir / "hmdnoded.json") << cfg.dump(1);
    signal_daemon(SIGHUP);
    EXPECT_EQ(notify->wait_ready(), "READY=1");
    st = wait_scene_loaded();
    EXPECT_EQ(st["scene"], kSmallScene) << st;
    EXPECT_EQ(st["objects"].get<int>(), 1) << st;
    EXPECT_EQ(st["scene_error"], "") << st;
    expect_frames_progress();

    std::ofstream(dir / "hmdnoded.json") << R"({"scene": "x.glb", "nonsense": 1})";
    signal_daemon(SIGHUP);
    EXPECT_EQ(notify->wait_for("RELOADING=1"), "RELOADING=1");
    EXPECT_EQ(notify->wait_ready(), "READY=1");
    st = ctl_json(sock, "status");
    EXPECT_DOUBLE_EQ(st["lod_tolerance_px"].get<double>(), 3.0) << "the running config is kept";
    expect_frames_progress();
    EXPECT_EQ(stop(), 0);
    const std::string log = read_text(dir / "log");
    EXPECT_NE(log.find("reload: "), std::string::npos);
    EXPECT_NE(log.find("unknown key \"nonsense\"; keeping the running config"), std::string::npos)
        << log;
}

// The commands that change the running node (docs/daemon.md, "Control socket"): warp,
// prediction offset, LOD bias, recentre, load-scene. Bad values are refused with an error naming
// the setting, a scene that cannot be read keeps the running one, a good one is swapped in, and
// the loop keeps presenting frames throughout.
TEST_F(DaemonControl, SettingsRecentreAndLoadSceneKeepTheLoopRunning) {
    EXPECT_EQ(ctl(sock, "set warp off").code, 0);
    EXPECT_FALSE(ctl_json(sock, "status")["warp"].get<bool>());
    expect_frames_progress();
    EXPECT_EQ(ctl(sock, "set warp on").code, 0);
    EXPECT_TRUE(ctl_json(sock, "status")["warp"].get<bool>());
    EXPECT_EQ(ctl(sock, "set prediction 12.5").code, 0);
    EXPECT_DOUBLE_EQ(ctl_json(sock, "status")["prediction_ms"].get<double>(), 12.5);
    hmdnode::test::CommandRun r = ctl(sock, "set prediction 500");
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.output.find("prediction offset must be between -100 and 100 ms"), std::string::npos)
        << r.output;
    EXPECT_EQ(ctl(sock, "set lod-bias 1").code, 0);
    EXPECT_DOUBLE_EQ(ctl_json(sock, "status")["lod_bias"].get<double>(), 1.0);
    EXPECT_EQ(ctl(sock, "set lod-bias lots").code, 2);
    EXPECT_EQ(ctl(sock, "set warp maybe").code, 2);
    EXPECT_EQ(ctl(sock, "recentre").code, 0);

    // Bad fields of the new commands: error replies, the loop undisturbed.
    RawClient bad(sock);
    ASSERT_TRUE(bad.connected());
    bad.send("{\"cmd\":\"load-scene\"}\n");
    EXPECT_NE(bad.reply_line().find("load-scene: give \\\"path\\\""), std::string::npos);
    bad.send("{\"cmd\":\"set\",\"key\":\"lod_bias\",\"value\":1e308}\n");
    EXPECT_NE(bad.reply_line().find("LOD bias must be between -8 and 8"), std::string::npos);
    bad.send("{\"cmd\":\"set\",\"key\":\"warp\",\"value\":1}\n");
    EXPECT_NE(bad.reply_line().find("\"ok\":false"), std::string::npos);
    expect_frames_progress();

    // load-scene: a missing file is refused at once; one that is not glTF keeps the running
    // scene (and the status says why); a good one is swapped in.
    r = ctl(sock, "load-scene " + (dir / "missing.glb").string());
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.output.find("no such file"), std::string::npos) << r.output;
    std::ofstream(dir / "garbage.glb") << "not a scene";
    EXPECT_EQ(ctl(sock, "load-scene " + (dir / "garbage.glb").string()).code, 0);
    nlohmann::json st = wait_scene_loaded();
    EXPECT_EQ(st["scene"], HMDNODE_DEMO_SCENE) << st;
    EXPECT_NE(st["scene_error"].get<std::string>().find("not glTF"), std::string::npos) << st;
    expect_frames_progress();
    EXPECT_EQ(ctl(sock, "load-scene " + kSmallScene).code, 0);
    st = wait_scene_loaded();
    EXPECT_EQ(st["scene"], kSmallScene) << st;
    EXPECT_EQ(st["objects"].get<int>(), 1) << st;
    expect_frames_progress();
    EXPECT_EQ(stop(), 0);
    const std::string log = read_text(dir / "log");
    EXPECT_NE(log.find("scene swapped: " + kSmallScene + " (1 objects)"), std::string::npos) << log;
}
