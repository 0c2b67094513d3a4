// The edges of the command lines (the service's usage conventions): every usage error exits 2, in
// every subcommand and in the daemon; no floating-point option takes nan or inf; implausible or
// inconsistent values are refused naming the option (or the config key); outputs are checked before
// the work, so a bad path fails at once and leaves nothing; a truncated capture keeps its whole
// records.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "firmware_host/command_run.hpp"

namespace fs = std::filesystem;

namespace {

using hmdnode::test::CommandRun;
using hmdnode::test::run;

const std::string kTool = HMDNODE_TOOL;
const std::string kDaemon = HMDNODE_DAEMON;
const std::string kScene = HMDNODE_DEMO_SCENE;
const std::string kTrace = HMDNODE_SOURCE_DIR "/data/traces/corbillon2018_user1.csv";

fs::path temp_dir(const std::string& name) {
    return hmdnode::test::fresh_temp_dir("hmdnode_cli_edges_" + name);
}

bool has(const std::string& text, const std::string& part) {
    return text.find(part) != std::string::npos;
}

// The subcommand names listed under "SUBCOMMANDS:" (CLI11's help) of `command --help`.
std::vector<std::string> subcommands_of(const std::string& command) {
    const CommandRun r = run(command + " --help");
    EXPECT_EQ(r.code, 0) << command << ": " << r.output;
    std::vector<std::string> names;
    std::istringstream in(r.output);
    std::string line;
    bool in_list = false;
    while (std::getline(in, line)) {
        if (line.rfind("Subcommands:", 0) == 0 || line.rfind("SUBCOMMANDS:", 0) == 0) {
            in_list = true;
            continue;
        }
        if (!in_list) continue;
        if (line.empty() || line[0] != ' ') break;
        std::istringstream ls(line);
        std::string name;
        if (ls >> name) names.push_back(name);
    }
    return names;
}

// Every leaf command of the tool ("replay", "trace import", ...), found from the help itself, so a
// subcommand added later is covered.
std::vector<std::string> leaf_commands(const std::string& prefix) {
    std::vector<std::string> out;
    for (const std::string& name : subcommands_of(kTool + prefix)) {
        const std::string path = prefix + " " + name;
        std::vector<std::string> below = leaf_commands(path);
        if (below.empty())
            out.push_back(path);
        else
            out.insert(out.end(), below.begin(), below.end());
    }
    return out;
}

std::string replay_cmd(const fs::path& report) {
    return kTool + " replay --quiet --eye-width 32 --eye-height 32 --duration 0.2 --scene " +
           kScene + " --trace " + kTrace + " --report " + report.string();
}

}  // namespace

TEST(CliEdges, EveryUsageErrorExits2) {
    const std::vector<std::string> leaves = leaf_commands("");
    // The tool's commands as docs/tools.md lists them, at least.
    const std::set<std::string> listed(leaves.begin(), leaves.end());
    for (const char* c : {" replay", " trace import", " scene demo", " lod", " bake", " record",
                          " latency", " capture info"})
        EXPECT_TRUE(listed.count(c)) << c << " not found in the help";
    for (const std::string& leaf : leaves) {
        const CommandRun r = run(kTool + leaf + " --no-such-option");
        // note: CLI11 may name a missing required option first; the status is what matters.
        EXPECT_EQ(r.code, 2) << leaf << ": " << r.output;
    }
    EXPECT_EQ(run(kTool).code, 2);
    EXPECT_EQ(run(kTool + " no-such-command").code, 2);
    EXPECT_EQ(run(kTool + " --help").code, 0);
    EXPECT_EQ(run(kTool + " replay --help").code, 0);
    // The daemon: its flags alike (a usage error must not look like a crash to systemd).
    EXPECT_EQ(run(kDaemon + " --no-such-flag").code, 2);
    EXPECT_EQ(run(kDaemon + " --max-frames many").code, 2);
    EXPECT_EQ(run(kDaemon + " --help").code, 0);
    // Options that do not go together, or a missing one the command checks itself.
    EXPECT_EQ(run(kTool + " lod --ratios 0.5").code, 2);
    EXPECT_EQ(run(kTool + " lod --in a.obj --out b.glb --algorithm no-such").code, 2);
    EXPECT_EQ(run(kTool + " pm refine --in a.hmpm --out b.txt").code, 2);
    EXPECT_EQ(run(kTool + " bake --in a.glb --out b.glb --samples 0").code, 2);
    EXPECT_EQ(run(kTool + " record --device 1209:0001 --backend sim --sim-clock").code, 2);
}

TEST(CliEdges, NoFloatingPointOptionTakesNanOrInf) {
    const fs::path dir = temp_dir("finite");
    const std::string base = replay_cmd(dir / "r.json");
    for (const char* opt : {"--noise-deg", "--refresh", "--lod-tolerance-px", "--latency-us",
                            "--persistence-ms", "--resample", "--start", "--ipd"})
        for (const char* value : {"nan", "inf", "-inf", "1e999"}) {
            const CommandRun r = run(base + " " + opt + " " + value);
            EXPECT_EQ(r.code, 2) << opt << " " << value << ": " << r.output;
            EXPECT_TRUE(has(r.output, opt)) << r.output;
            // note: an option's range check may see inf first ("not in range"); nan passes
            // every range check, so only the finite check refuses it.
            if (std::string(value) == "nan") {
                EXPECT_TRUE(has(r.output, "not a finite number")) << opt << " " << r.output;
            }
        }
    // Vectors of numbers too (bake --sky R,G,B), and other commands' options.
    CommandRun r = run(kTool + " bake --in a.glb --out b.glb --sky 1,nan,0");
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_TRUE(has(r.output, "--sky")) << r.output;
    r = run(kTool + " record --device 1209:0001 --backend sim --duration inf --out x.csv");
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_FALSE(fs::exists(dir / "r.json"));
}

TEST(CliEdges, ImplausibleOrInconsistentValuesAreRefusedNamingTheOption) {
    const fs::path dir = temp_dir("values");
    const std::string base = replay_cmd(dir / "r.json");
    struct Case {
        std::string args, names;
    };
    // --resample 1e8 made every sample up front and died of bad_alloc: now a range.
    for (const Case& c :
         std::vector<Case>{{"--resample 1e8", "--resample"},
                           {"--lod-tolerance-px -1", "--lod-tolerance-px"},
                           {"--noise-deg -2", "--noise-deg"},
                           {"--allocator annealing", "--allocator"},
                           {"--persistence-ms 20", "--persistence-ms"},
                           {"--refresh 120 --persistence-ms 9", "refresh period"}}) {
        const CommandRun r = run(base + " " + c.args);
        EXPECT_EQ(r.code, 2) << c.args << ": " << r.output;
        EXPECT_TRUE(has(r.output, c.names)) << c.args << ": " << r.output;
        EXPECT_FALSE(has(r.output, "bad_alloc")) << r.output;
    }
    EXPECT_FALSE(fs::exists(dir / "r.json"));
    // The edge values themselves are fine: persistence of a whole period, the highest rate.
    const CommandRun ok = run(base + " --refresh 100 --persistence-ms 10 --resample 4000");
    EXPECT_EQ(ok.code, 0) << ok.output;
    EXPECT_TRUE(fs::exists(dir / "r.json"));
}

TEST(CliEdges, TheDaemonRefusesTheSameValuesInItsConfigNamingTheKey) {
    const fs::path dir = temp_dir("daemon_values");
    const nlohmann::json good = {
        {"scene", kScene},
        {"clock", "sim"},
        {"tracker", {{"type", "sim"}, {"trace", kTrace}}},
        {"display", {{"eye_width", 32}, {"eye_height", 32}, {"refresh_hz", 90}}}};
    struct Case {
        std::string pointer;
        nlohmann::json value;
        std::string names;
    };
    for (const Case& c :
         std::vector<Case>{{"/tracker/resample_hz", 1e8, "tracker.resample_hz"},
                           {"/tracker/noise_deg", -1.0, "tracker.noise_deg"},
                           {"/display/persistence_ms", 20.0, "display.persistence_ms"},
                           {"/node/lod_tolerance_px", -1.0, "node.lod_tolerance_px"},
                           {"/node/prediction_ms", 150.0, "node.prediction_ms"},
                           {"/node/lod_bias", -9.0, "node.lod_bias"},
                           {"/node/lod_allocator", "annealing", "node.lod_allocator"},
                           {"/node/lod_fade_frames", 16, "node.lod_fade_frames"},
                           {"/display/msaa", 2, "display.msaa"}}) {
        nlohmann::json cfg = good;
        cfg[nlohmann::json::json_pointer(c.pointer)] = c.value;
        std::ofstream(dir / "hmdnoded.json") << cfg.dump(1);
        const CommandRun r =
            run(kDaemon + " --max-frames 1 --config " + (dir / "hmdnoded.json").string());
        EXPECT_EQ(r.code, 2) << c.pointer << ": " << r.output;
        EXPECT_TRUE(has(r.output, c.names)) << r.output;
    }
    // JSON has no nan; a number too large for a double is refused (it aborted the daemon).
    std::string text = good.dump(1);
    text.replace(text.find("\"refresh_hz\": 90"), 16, "\"refresh_hz\": 1e999");
    std::ofstream(dir / "hmdnoded.json") << text;
    const CommandRun r =
        run(kDaemon + " --max-frames 1 --config " + (dir / "hmdnoded.json").string());
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_TRUE(has(r.output, "1e999")) << r.output;
    EXPECT_TRUE(has(r.output, "hmdnoded.json")) << r.output;
}

// The report used to be checked after the whole replay: the frames were written, then it failed.
TEST(CliEdges, OutputsAreCheckedBeforeTheWorkAndNothingIsLeft) {
    const fs::path dir = temp_dir("outputs");
    fs::create_directory(dir / "taken");
    for (const fs::path& bad : {dir / "missing" / "r.json", dir / "taken"}) {
        const CommandRun r = run(replay_cmd(bad) + " --frames " + (dir / "frames").string());
        EXPECT_EQ(r.code, 1) << r.output;
        EXPECT_TRUE(has(r.output, bad.string())) << r.output;
        EXPECT_FALSE(fs::exists(dir / "frames")) << "the work started before the check";
    }
    const std::string missing = (dir / "missing" / "x").string();
    struct Case {
        std::string args, flag;
    };
    for (const Case& c : std::vector<Case>{
             {" trace import --from " + kTrace + " --to " + missing, "--to"},
             {" latency --clock sim --frame-cost-ms 4 --duration 0.2 --eye-width 16 "
              "--eye-height 16 --scene " +
                  kScene + " --report " + missing,
              "--report"},
             {" bake --in " + kScene + " --out " + missing, "--out"},
             {" record --device 1209:0001 --backend sim --sim-clock --duration 0.1 --out " +
                  (dir / "ok.csv").string() + " --capture " + missing,
              "--capture"},
             {" scene demo --data " HMDNODE_SOURCE_DIR "/data --out " + missing, "--out"}}) {
        const CommandRun r = run(kTool + c.args);
        EXPECT_EQ(r.code, 1) << c.args << ": " << r.output;
        EXPECT_TRUE(has(r.output, c.flag + " " + missing)) << r.output;
        EXPECT_TRUE(has(r.output, "does not exist")) << r.output;
        EXPECT_TRUE(has(r.output, "nothing written")) << r.output;
    }
    std::set<std::string> left;
    for (const auto& e : fs::directory_iterator(dir)) left.insert(e.path().filename().string());
    EXPECT_EQ(left, (std::set<std::string>{"taken"}));
}

// A recording cut short (the recorder killed, the disk full) replays its whole records, with a
// warning naming the byte offset of the cut one.
TEST(CliEdges, ATruncatedCaptureYieldsItsGoodRecordsWithAWarning) {
    const fs::path dir = temp_dir("truncated");
    const fs::path pcap = dir / "rec.pcap";
    CommandRun r =
        run(kTool + " record --device 1209:0001 --backend sim --sim-clock --duration 1 " +
            "--capture " + pcap.string());
    ASSERT_EQ(r.code, 0) << r.output;
    const uintmax_t size = fs::file_size(pcap);
    fs::resize_file(pcap, size - 7);
    r = run(kTool + " capture info " + pcap.string());
    EXPECT_EQ(r.code, 0) << r.output;
    EXPECT_TRUE(has(r.output, "warning: " + pcap.string() + ": pcap: record ")) << r.output;
    EXPECT_TRUE(has(r.output, " at byte ")) << r.output;
    EXPECT_TRUE(has(r.output, "is cut short")) << r.output;
    // The same file through the device tracker: the good reports make a trace.
    r = run(kTool + " record --device 1209:0001 --backend capture --from " + pcap.string() +
            " --out " + (dir / "again.csv").string());
    EXPECT_EQ(r.code, 0) << r.output;
    EXPECT_TRUE(has(r.output, "is cut short")) << r.output;
    EXPECT_TRUE(fs::exists(dir / "again.csv"));
}
