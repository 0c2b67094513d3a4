// The trace CSV (reader, writer, interpolation, figures) and the table importer, against small
// hand-made tables, the Corbillon et al. 2018 excerpt and the full recordings in tests/data/traces.
#include "hmdnode/core/trace.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/core/pose.hpp"
#include "hmdnode/core/time.hpp"

namespace hmdnode {
namespace {

namespace fs = std::filesystem;

const fs::path kData = fs::path(HMDNODE_SOURCE_DIR) / "tests" / "data" / "traces";
const fs::path kShared = fs::path(HMDNODE_SOURCE_DIR) / "tests" / "data" / "traces";

fs::path temp_dir() {
    fs::path dir = fs::path(HMDNODE_BINARY_DIR) / "test_tmp" / "trace";
    fs::create_directories(dir);
    return dir;
}

bool same_bits(double a, double b) {
    return std::memcmp(&a, &b, sizeof a) == 0;
}

bool contains(const std::string& haystack, const std::string& needle) {
    return haystack.find(needle) != std::string::npos;
}

// Expects an error whose message holds every one of `parts`.
template <class T>
void expect_error(const Result<T>& r, std::initializer_list<std::string> parts) {
    ASSERT_FALSE(r.ok());
    for (const std::string& p : parts)
        EXPECT_TRUE(contains(r.error().message, p))
            << "'" << p << "' not in: " << r.error().message;
}

glm::dquat yaw_quat(double yaw_rad) {
    return glm::angleAxis(yaw_rad, glm::dvec3(0, 1, 0));
}

// Checks the invariants every trace must hold: strictly increasing time, unit quaternions, no
// hemisphere jumps between neighbours.
void expect_valid(const Trace& t) {
    for (size_t i = 0; i < t.samples.size(); ++i) {
        const glm::dquat& q = t.samples[i].orientation;
        EXPECT_NEAR(glm::length(q), 1.0, 1e-12) << "sample " << i;
        if (i == 0) continue;
        EXPECT_GT(t.samples[i].time_ns, t.samples[i - 1].time_ns) << "sample " << i;
        EXPECT_GE(glm::dot(q, t.samples[i - 1].orientation), 0.0) << "sample " << i;
    }
}

// --- Reader and writer
// ----------------------------------------------------------------------------

Trace make_full_trace() {
    Trace t;
    t.comments = {"made by make_full_trace", "second comment, with a comma"};
    uint64_t state = 12345;
    auto rnd = [&] {
        state = state * 6364136223846793005ull + 1442695040888963407ull;
        return double(state >> 11) / double(1ull << 53) * 2.0 - 1.0;
    };
    glm::dquat prev(1, 0, 0, 0);
    for (int i = 0; i < 200; ++i) {
        TraceSample s;
        s.time_ns = 1'700'000'000'000'000'000 + int64_t(i) * 11'111'111 + (i % 3);
        glm::dquat q = glm::normalize(glm::dquat(rnd(), rnd(), rnd(), rnd()));
        s.orientation = same_hemisphere(q, prev);
        prev = s.orientation;
        s.position = glm::dvec3(rnd() * 3, 1.6 + rnd() * 1e-7, rnd() / 3.0);
        s.gyro = glm::dvec3(rnd() * 10, rnd() * 1e-300, -rnd());
        s.accel = glm::dvec3(rnd() * 9.81, 1e300 * rnd(), rnd());
        t.samples.push_back(s);
    }
    return t;
}

TEST(TraceCsv, WriteThenReadIsBitExact) {
    const Trace in = make_full_trace();
    const fs::path path = temp_dir() / "round_trip.csv";
    ASSERT_TRUE(write_trace_csv(in, path).ok());
    Result<Trace> out = read_trace_csv(path);
    ASSERT_TRUE(out.ok()) << out.error().message;
    EXPECT_EQ(out->comments, in.comments);
    ASSERT_EQ(out->samples.size(), in.samples.size());
    for (size_t i = 0; i < in.samples.size(); ++i) {
        const TraceSample& a = in.samples[i];
        const TraceSample& b = out->samples[i];
        EXPECT_EQ(a.time_ns, b.time_ns);
        for (int k = 0; k < 4; ++k) EXPECT_TRUE(same_bits(a.orientation[k], b.orientation[k])) << i;
        for (int k = 0; k < 3; ++k) {
            EXPECT_TRUE(same_bits((*a.position)[k], (*b.position)[k])) << i;
            EXPECT_TRUE(same_bits((*a.gyro)[k], (*b.gyro)[k])) << i;
            EXPECT_TRUE(same_bits((*a.accel)[k], (*b.accel)[k])) << i;
        }
    }
    // Writing what was read gives the same bytes.
    Result<std::string> first = read_file(path);
    Result<std::string> second = format_trace_csv(*out);
    ASSERT_TRUE(first.ok() && second.ok());
    EXPECT_EQ(*first, *second);
    EXPECT_EQ(first->rfind("# hmdnode trace v1\n", 0), 0u);
}

TEST(TraceCsv, WritesOnlyTheGroupsPresent) {
    Trace t;
    t.samples.push_back(
        {0, glm::dquat(1, 0, 0, 0), std::nullopt, std::nullopt, std::nullopt, std::nullopt});
    t.samples.push_back({5, yaw_quat(0.1), std::nullopt, std::nullopt, std::nullopt, std::nullopt});
    Result<std::string> text = format_trace_csv(t);
    ASSERT_TRUE(text.ok());
    EXPECT_EQ(*text,
              "# hmdnode trace v1\ntime_ns,qw,qx,qy,qz\n0,1,0,0,0\n5,0.9987502603949663,0,"
              "0.04997916927067833,0\n");
}

TEST(TraceCsv, WriterRefusesWhatTheReaderWouldReject) {
    expect_error(format_trace_csv(Trace{}), {"no samples"});
    Trace t;
    t.samples.push_back(
        {10, glm::dquat(1, 0, 0, 0), glm::dvec3(0), std::nullopt, std::nullopt, std::nullopt});
    t.samples.push_back(
        {10, glm::dquat(1, 0, 0, 0), glm::dvec3(0), std::nullopt, std::nullopt, std::nullopt});
    expect_error(format_trace_csv(t), {"sample 1", "not after"});
    t.samples[1].time_ns = 20;
    t.samples[1].position.reset();
    expect_error(format_trace_csv(t), {"sample 1", "different set"});
    t.samples[1].position = glm::dvec3(std::nan(""), 0, 0);
    expect_error(format_trace_csv(t), {"not finite"});
    t.samples[1].position = glm::dvec3(0);
    t.samples[1].orientation = glm::dquat(0, 0, 0, 0);
    expect_error(format_trace_csv(t), {"quaternion norm"});
    t.samples[1].orientation = glm::dquat(1, 0, 0, 0);
    t.comments = {"two\nlines"};
    expect_error(format_trace_csv(t), {"line break"});
    // A failed write leaves no file behind.
    const fs::path path = temp_dir() / "refused.csv";
    fs::remove(path);
    EXPECT_FALSE(write_trace_csv(t, path).ok());
    EXPECT_FALSE(fs::exists(path));
}

TEST(TraceCsv, ReadsTheDocumentedExample) {
    Result<Trace> t = read_trace_csv(kData / "small_trace.csv");
    ASSERT_TRUE(t.ok()) << t.error().message;
    ASSERT_EQ(t->samples.size(), 4u);
    ASSERT_EQ(t->comments.size(), 1u);  // the version line is not a comment of the trace
    EXPECT_TRUE(contains(t->comments[0], "Turning left"));
    const TraceSample& s = t->samples[3];
    EXPECT_EQ(s.time_ns, 30'000'000);
    ASSERT_TRUE(s.position && s.gyro);
    EXPECT_FALSE(s.accel);
    EXPECT_DOUBLE_EQ(s.position->z, -0.003);
    EXPECT_DOUBLE_EQ(s.gyro->y, 0.5);
    EXPECT_NEAR(angle_between_rad(s.orientation, yaw_quat(0.015)), 0.0, 1e-12);
}

TEST(TraceCsv, AcceptsCrlfBlankLinesCommentsAndAnyColumnOrder) {
    const std::string text =
        "# hmdnode trace v1\r\n# first\r\n\r\nqx,time_ns,qz,qw,qy\r\n0,100,0,1,0\r\n  \r\n"
        "# between\rsamples\r\n0,200,0,0.5,0.8660254037844386\r\n";
    Result<Trace> t = parse_trace_csv(text, "crlf.csv");
    ASSERT_TRUE(t.ok()) << t.error().message;
    ASSERT_EQ(t->samples.size(), 2u);
    // A stray carriage return inside a comment is dropped.
    EXPECT_EQ(t->comments, (std::vector<std::string>{"first", "betweensamples"}));
    EXPECT_EQ(t->samples[1].time_ns, 200);
    EXPECT_DOUBLE_EQ(t->samples[1].orientation.w, 0.5);
    EXPECT_DOUBLE_EQ(t->samples[1].orientation.y, 0.8660254037844386);
    EXPECT_FALSE(t->samples[0].position);
}

TEST(TraceCsv, KeepsNeighboursInOneHemisphereAndNormalises) {
    const std::string text = "time_ns,qw,qx,qy,qz\n0,1,0,0,0\n1,-0.99,0,-0.1,0\n2,1.05,0,0.2,0\n";
    Result<Trace> t = parse_trace_csv(text, "flip.csv");
    ASSERT_TRUE(t.ok()) << t.error().message;
    expect_valid(*t);
    EXPECT_GT(t->samples[1].orientation.w, 0.0);  // -q taken
    EXPECT_NEAR(glm::length(t->samples[2].orientation), 1.0, 1e-15);
}

TEST(TraceCsv, MissingRequiredColumnNamesFileLineAndColumn) {
    expect_error(parse_trace_csv("# c\ntime_ns,qx,qy,qz\n0,0,0,0\n", "a.csv"), {"a.csv:2:", "qw"});
    expect_error(parse_trace_csv("qw,qx,qy,qz\n1,0,0,0\n", "a.csv"), {"a.csv:1:", "time_ns"});
    expect_error(parse_trace_csv("time_ns,qw,qx,qy,qz,px,py\n", "a.csv"),
                 {"a.csv:1:", "incomplete", "pz"});
}

TEST(TraceCsv, UnknownAndDuplicateColumnsAreErrors) {
    expect_error(parse_trace_csv("time_ns,qw,qx,qy,qz,temp,qW\n", "u.csv"),
                 {"u.csv:1:", "'temp'", "'qW'", "unknown column"});
    expect_error(parse_trace_csv("time_ns,qw,qx,qy,qz,qw\n", "u.csv"),
                 {"u.csv:1:", "column 6 'qw'", "duplicate"});
}

TEST(TraceCsv, NonNumericFieldNamesLineColumnAndText) {
    expect_error(parse_trace_csv("time_ns,qw,qx,qy,qz\n0,1,0,0,0\n1,1,abc,0,0\n", "n.csv"),
                 {"n.csv:3:", "column 3 'qx'", "'abc'"});
    expect_error(parse_trace_csv("time_ns,qw,qx,qy,qz\n0,1,0,0,nan\n", "n.csv"),
                 {"n.csv:2:", "column 5 'qz'", "finite", "'nan'"});
    expect_error(parse_trace_csv("time_ns,qw,qx,qy,qz\n0.5,1,0,0,0\n", "n.csv"),
                 {"n.csv:2:", "column 1 'time_ns'", "integer", "'0.5'"});
    expect_error(parse_trace_csv("time_ns,qw,qx,qy,qz\n0,1,,0,0\n", "n.csv"),
                 {"n.csv:2:", "column 3 'qx'", "not a number"});
}

TEST(TraceCsv, TimeGoingBackwardsOrRepeatingNamesBothValues) {
    expect_error(parse_trace_csv("time_ns,qw,qx,qy,qz\n500,1,0,0,0\n400,1,0,0,0\n", "b.csv"),
                 {"b.csv:3:", "column 1 'time_ns'", "time goes backwards", "400", "500"});
    expect_error(parse_trace_csv("time_ns,qw,qx,qy,qz\n500,1,0,0,0\n\n500,1,0,0,0\n", "b.csv"),
                 {"b.csv:4:", "column 1 'time_ns'", "repeated time 500", "line 2"});
}

TEST(TraceCsv, WrongFieldCountNamesLineAndColumn) {
    expect_error(parse_trace_csv("time_ns,qw,qx,qy,qz\n0,1,0,0\n", "f.csv"),
                 {"f.csv:2:", "found 4 fields", "column 5 'qz'", "missing"});
    expect_error(parse_trace_csv("time_ns,qw,qx,qy,qz\n0,1,0,0,0,7\n", "f.csv"),
                 {"f.csv:2:", "found 6 fields", "column 6", "extra"});
}

TEST(TraceCsv, BadQuaternionNamesLineAndColumns) {
    expect_error(parse_trace_csv("time_ns,qw,qx,qy,qz\n0,0,0,0,0\n", "q.csv"),
                 {"q.csv:2:", "columns 2,3,4,5", "norm 0", "zero"});
    expect_error(parse_trace_csv("time_ns,qx,qy,qz,qw\n0,0,0,0,1.2\n", "q.csv"),
                 {"q.csv:2:", "columns 5,2,3,4 (qw,qx,qy,qz)", "norm 1.2"});
    EXPECT_TRUE(parse_trace_csv("time_ns,qw,qx,qy,qz\n0,1.09,0,0,0\n", "q.csv").ok());
}

TEST(TraceCsv, EmptyTraceAndOtherVersionsAreErrors) {
    expect_error(parse_trace_csv("# hmdnode trace v1\ntime_ns,qw,qx,qy,qz\n\n", "e.csv"),
                 {"e.csv:2:", "no samples"});
    expect_error(parse_trace_csv("", "e.csv"), {"e.csv", "no header"});
    expect_error(parse_trace_csv("# hmdnode trace v3\ntime_ns,qw,qx,qy,qz\n0,1,0,0,0\n", "e.csv"),
                 {"e.csv:1:", "unsupported trace version", "v1 and v2"});
    expect_error(read_trace_csv(temp_dir() / "does_not_exist.csv"), {"does_not_exist.csv"});
}

// --- Gaze columns (v2)
// ----------------------------------------------------------------------------

TEST(TraceGaze, GazeColumnsRoundTripBitExactAndWriteV2) {
    Trace in = make_full_trace();
    uint64_t state = 99;
    for (size_t i = 0; i < in.samples.size(); ++i) {
        state = state * 6364136223846793005ull + 1442695040888963407ull;
        const double a = double(state >> 11) / double(1ull << 53);
        const glm::dvec3 d = glm::normalize(glm::dvec3(a - 0.5, 0.3 * a, -1.0));
        // Every fifth sample a blink: confidence 0, a zero direction allowed.
        in.samples[i].gaze = i % 5 == 0 ? TraceGaze{glm::dvec3(0.0), 0.0} : TraceGaze{d, a};
    }
    const fs::path path = temp_dir() / "gaze_round_trip.csv";
    ASSERT_TRUE(write_trace_csv(in, path).ok());
    Result<Trace> out = read_trace_csv(path);
    ASSERT_TRUE(out.ok()) << out.error().message;
    ASSERT_EQ(out->samples.size(), in.samples.size());
    for (size_t i = 0; i < in.samples.size(); ++i) {
        ASSERT_TRUE(out->samples[i].gaze.has_value());
        const TraceGaze& a = *in.samples[i].gaze;
        const TraceGaze& b = *out->samples[i].gaze;
        for (int k = 0; k < 3; ++k) EXPECT_TRUE(same_bits(a.direction[k], b.direction[k])) << i;
        EXPECT_TRUE(same_bits(a.confidence, b.confidence)) << i;
        EXPECT_EQ(a.valid(), b.valid());
    }
    Result<std::string> text = read_file(path);
    ASSERT_TRUE(text.ok());
    EXPECT_EQ(text->rfind("# hmdnode trace v2\n", 0), 0u);
    EXPECT_TRUE(contains(*text, ",ax,ay,az,gaze_x,gaze_y,gaze_z,gaze_conf\n"));
    // Without gaze the writer still writes v1 (old readers read it) and the reader gives none.
    Result<Trace> old =
        parse_trace_csv("# hmdnode trace v1\ntime_ns,qw,qx,qy,qz\n0,1,0,0,0\n", "old.csv");
    ASSERT_TRUE(old.ok());
    EXPECT_FALSE(old->samples[0].gaze.has_value());
    EXPECT_FALSE(compute_trace_stats(*old).has_gaze);
}

TEST(TraceGaze, BadGazeValuesNameFileLineAndColumn) {
    const std::string head =
        "# hmdnode trace v2\ntime_ns,qw,qx,qy,qz,gaze_x,gaze_y,gaze_z,gaze_conf\n";
    expect_error(parse_trace_csv(head + "0,1,0,0,0,0,0,-1,1\n5,1,0,0,0,0,0,-1,1.5\n", "g.csv"),
                 {"g.csv:4:", "column 9 'gaze_conf'", "outside [0, 1]", "1.5"});
    expect_error(parse_trace_csv(head + "0,1,0,0,0,0,0,-1,-0.1\n", "g.csv"),
                 {"g.csv:3:", "column 9 'gaze_conf'"});
    expect_error(parse_trace_csv(head + "0,1,0,0,0,0,0,-2,1\n", "g.csv"),
                 {"g.csv:3:", "columns 6,7,8 (gaze_x,gaze_y,gaze_z)", "norm 2"});
    expect_error(parse_trace_csv(head + "0,1,0,0,0,0,abc,-1,1\n", "g.csv"),
                 {"g.csv:3:", "column 7 'gaze_y'", "not a number", "'abc'"});
    expect_error(parse_trace_csv(head + "0,1,0,0,0,0,0,nan,1\n", "g.csv"),
                 {"g.csv:3:", "column 8 'gaze_z'", "not a finite number"});
    expect_error(
        parse_trace_csv("time_ns,qw,qx,qy,qz,gaze_x,gaze_y,gaze_z\n0,1,0,0,0,0,0,-1\n", "g.csv"),
        {"g.csv:1:", "incomplete column group", "gaze_conf"});
    // A blink (confidence 0) may have any finite direction; a valid gaze near unit length is
    // normalised.
    Result<Trace> ok =
        parse_trace_csv(head + "0,1,0,0,0,0,0,0,0\n5,1,0,0,0,0,0,-1.05,1\n", "g.csv");
    ASSERT_TRUE(ok.ok()) << ok.error().message;
    EXPECT_FALSE(ok->samples[0].gaze->valid());
    EXPECT_NEAR(ok->samples[1].gaze->direction.z, -1.0, 1e-15);
    // The writer refuses what the reader would.
    Trace t = *ok;
    t.samples[1].gaze->confidence = 2.0;
    expect_error(format_trace_csv(t), {"sample 1", "confidence"});
    t.samples[1].gaze.reset();
    expect_error(format_trace_csv(t), {"sample 1", "gaze"});
}

// --- Interpolation and figures
// --------------------------------------------------------------------

Trace two_sample_trace(bool flip_second) {
    Trace t;
    TraceSample a, b;
    a.time_ns = 1'000'000'000;
    a.orientation = glm::dquat(1, 0, 0, 0);
    a.position = glm::dvec3(0, 1.6, 0);
    b.time_ns = 2'000'000'000;
    b.orientation = yaw_quat(deg_to_rad(90)) * (flip_second ? -1.0 : 1.0);
    b.position = glm::dvec3(1, 1.6, -2);
    t.samples = {a, b};
    return t;
}

TEST(TracePoseAt, SlerpsAtTheMidpointAndLerpsPosition) {
    for (bool flip : {false, true}) {
        const Trace t = two_sample_trace(flip);
        Pose p = t.pose_at(1'500'000'000);
        EXPECT_EQ(p.time_ns, 1'500'000'000);
        EXPECT_NEAR(angle_between_deg(p.orientation, yaw_quat(deg_to_rad(45))), 0.0, 1e-9);
        EXPECT_NEAR(p.position.x, 0.5, 1e-15);
        EXPECT_NEAR(p.position.z, -1.0, 1e-15);
        ASSERT_TRUE(p.angular_velocity && p.linear_velocity);
        EXPECT_NEAR(p.angular_velocity->y, deg_to_rad(90), 1e-9);  // rad/s over 1 s
        EXPECT_NEAR(p.linear_velocity->z, -2.0, 1e-12);
        // A quarter of the way: 22.5 degrees (slerp, not a lerp of the components).
        Pose q = t.pose_at(1'250'000'000);
        EXPECT_NEAR(angle_between_deg(q.orientation, yaw_quat(deg_to_rad(22.5))), 0.0, 1e-9);
    }
}

TEST(TracePoseAt, ClampsAtTheEndsAndReturnsSamplesExactly) {
    const Trace t = two_sample_trace(false);
    Pose before = t.pose_at(0);
    EXPECT_EQ(before.orientation, t.samples[0].orientation);
    EXPECT_EQ(before.position, *t.samples[0].position);
    EXPECT_EQ(*before.angular_velocity, glm::dvec3(0.0));
    Pose after = t.pose_at(9'000'000'000);
    EXPECT_EQ(after.orientation, t.samples[1].orientation);
    EXPECT_EQ(after.position, *t.samples[1].position);
    EXPECT_EQ(*after.linear_velocity, glm::dvec3(0.0));
    EXPECT_EQ(t.pose_at(2'000'000'000).orientation, t.samples[1].orientation);
    EXPECT_EQ(t.pose_at(1'000'000'000).orientation, t.samples[0].orientation);
}

TEST(TracePoseAt, UsesGyroForAngularVelocityWhenPresent) {
    Result<Trace> t = read_trace_csv(kData / "small_trace.csv");
    ASSERT_TRUE(t.ok());
    Pose p = t->pose_at(15'000'000);
    EXPECT_NEAR(angle_between_rad(p.orientation, yaw_quat(0.0075)), 0.0, 1e-12);
    ASSERT_TRUE(p.angular_velocity);
    EXPECT_NEAR(glm::length(*p.angular_velocity - glm::dvec3(0, 0.5, 0)), 0.0, 1e-12);
    EXPECT_NEAR(p.position.z, -0.0015, 1e-15);
}

TEST(TraceStatsTest, FiguresOfATrace) {
    Trace t;
    const int64_t times[] = {0, 10, 20, 30, 250, 260};  // ms
    for (int i = 0; i < 6; ++i)
        t.samples.push_back({times[i] * kNsPerMs, yaw_quat(deg_to_rad(i == 5 ? 3.0 : 0.0)),
                             std::nullopt, std::nullopt, std::nullopt, std::nullopt});
    TraceStats st = compute_trace_stats(t);
    EXPECT_EQ(st.samples, 6u);
    EXPECT_EQ(st.duration_ns, 260 * kNsPerMs);
    EXPECT_EQ(st.median_interval_ns, 10 * kNsPerMs);
    EXPECT_NEAR(st.median_rate_hz, 100.0, 1e-9);
    EXPECT_EQ(st.longest_gap_ns, 220 * kNsPerMs);
    EXPECT_EQ(st.longest_gap_start_ns, 30 * kNsPerMs);
    EXPECT_EQ(st.gaps_over_100ms, 1u);
    EXPECT_NEAR(st.max_angular_speed_deg_s, 300.0, 1e-6);  // 3 degrees in 10 ms
    EXPECT_EQ(st.max_angular_speed_at_ns, 250 * kNsPerMs);
}

// --- Importer: real data
// --------------------------------------------------------------------------

struct CorbillonExpect {
    size_t rows;
    size_t sign_flips;
    size_t gaps_over_100ms;
    int64_t longest_gap_ns;
    int64_t last_ns;
};

void check_corbillon_import(const fs::path& path, const CorbillonExpect& e) {
    TraceImportReport rep;
    Result<Trace> t = import_trace_table(path, TraceImportOptions{}, &rep);
    ASSERT_TRUE(t.ok()) << t.error().message;
    EXPECT_EQ(rep.rows_read, e.rows);
    EXPECT_EQ(rep.duplicate_times_dropped, 0u);  // these recordings repeat poses, not times
    EXPECT_EQ(rep.samples_written, rep.rows_read - rep.duplicate_times_dropped);
    EXPECT_EQ(t->samples.size(), rep.samples_written);
    EXPECT_EQ(rep.header_lines_skipped, 1u);
    EXPECT_EQ(rep.sign_flips_fixed, e.sign_flips);
    EXPECT_GT(rep.sign_flips_fixed, 0u);
    EXPECT_EQ(rep.gaps_over_100ms, e.gaps_over_100ms);
    EXPECT_NEAR(double(rep.longest_gap_ns), double(e.longest_gap_ns), 1.0);
    EXPECT_EQ(rep.non_unit_normalized, 0u);
    EXPECT_EQ(t->samples.front().time_ns, 0);
    EXPECT_NEAR(double(t->samples.back().time_ns), double(e.last_ns), 1.0);
    expect_valid(*t);
    TraceStats st = compute_trace_stats(*t);
    EXPECT_EQ(st.longest_gap_ns, rep.longest_gap_ns);
    EXPECT_EQ(st.gaps_over_100ms, rep.gaps_over_100ms);
    EXPECT_NEAR(st.median_rate_hz, 58.8, 1.0);
    bool viewpoint_ignored = false;
    for (const std::string& n : rep.notes)
        if (contains(n, "ignored") && contains(n, "viewpoint")) viewpoint_ignored = true;
    EXPECT_TRUE(viewpoint_ignored);
    // The imported trace is a valid trace file.
    const fs::path out = temp_dir() / (path.stem().string() + ".trace.csv");
    ASSERT_TRUE(write_trace_csv(*t, out).ok());
    Result<Trace> back = read_trace_csv(out);
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_EQ(back->samples.size(), t->samples.size());
}

TEST(TraceImport, CorbillonExcerptWithAutoOptions) {
    check_corbillon_import(kData / "corbillon2018_user1_head.txt",
                           {399, 228, 3, 242'004'395, 7'260'002'136});
    // Rows 2 and 3 of the source: the same orientation at new times, then a sign flip.
    TraceImportReport rep;
    Result<Trace> t = import_trace_table(kData / "corbillon2018_user1_head.txt", {}, &rep);
    ASSERT_TRUE(t.ok());
    EXPECT_EQ(t->samples[1].time_ns, 111'000'061);
    EXPECT_EQ(t->samples[1].orientation, t->samples[0].orientation);
    EXPECT_EQ(rep.repeated_orientations, 20u);
    // Unit quaternions keep the source's bits; a flip only changes the signs.
    EXPECT_EQ(t->samples[0].orientation.w, 0.9968662107341499);
    EXPECT_EQ(t->samples[2].orientation.w, 0.9944422462475966);  // source: -0.9944422462475966
    EXPECT_EQ(t->samples[2].orientation.x, -0.05501044054766731);
}

TEST(TraceImport, FullCorbillonRecordingsBundledInTheRepository) {
    const fs::path user1 = kShared / "corbillon2018_user1_quaternion.txt";
    const fs::path user2 = kShared / "corbillon2018_user2_quaternion.txt";
    if (!fs::exists(user1) || !fs::exists(user2)) FAIL() << "recordings missing in " << kShared;
    check_corbillon_import(user1, {16053, 8123, 3, 242'004'395, 272'055'999'756});
    check_corbillon_import(user2, {17379, 8755, 4, 263'999'939, 296'854'995'728});
}

TEST(TraceImport, MessyExportIsRepairedAndEachRepairCounted) {
    TraceImportReport rep;
    Result<Trace> t = import_trace_table(kData / "messy_export.csv", {}, &rep);
    ASSERT_TRUE(t.ok()) << t.error().message;
    EXPECT_TRUE(contains(rep.separator, "semicolon"));
    EXPECT_EQ(rep.header_lines_skipped, 4u);
    EXPECT_EQ(rep.rows_read, 7u);
    EXPECT_EQ(rep.duplicate_times_dropped, 2u);
    EXPECT_EQ(rep.duplicate_times_conflicting, 1u);
    EXPECT_EQ(rep.samples_written, 5u);
    EXPECT_EQ(rep.sign_flips_fixed, 1u);
    EXPECT_EQ(rep.non_unit_normalized, 2u);
    EXPECT_EQ(rep.gaps_over_100ms, 1u);
    EXPECT_EQ(rep.longest_gap_ns, 250 * kNsPerMs);
    EXPECT_EQ(rep.repeated_orientations, 1u);
    EXPECT_EQ(rep.comment_lines_skipped, 1u);
    EXPECT_TRUE(rep.truncated_last_row_dropped);
    EXPECT_EQ(rep.time_offset_ns, 1000 * kNsPerMs);
    ASSERT_EQ(t->samples.size(), 5u);
    expect_valid(*t);
    const int64_t want_ns[] = {0, 16'500'000, 33'000'000, 283'000'000, 300'000'000};
    for (size_t i = 0; i < 5; ++i) EXPECT_EQ(t->samples[i].time_ns, want_ns[i]) << i;
    // The first row at a repeated time is kept (not the conflicting 0.05 one).
    EXPECT_NEAR(t->samples[2].orientation.y, 0.0261769, 1e-7);
    // xyzw by name; position from pos_x,pos_y,pos_z; 'tracking' ignored.
    ASSERT_TRUE(t->samples[3].position);
    EXPECT_DOUBLE_EQ(t->samples[3].position->z, 0.01);
    EXPECT_NEAR(t->samples[3].orientation.y, 0.04 / std::sqrt(0.990025 + 0.0016), 1e-15);
}

// --- Importer: options ---------------------------------------------------------------------------

const char* const kTableSeconds =
    "t,qw,qx,qy,qz\n"
    "12.000,1,0,0,0\n"
    "12.0166667,0.9998477,0,0.0174524,0\n"
    "12.05,0.9993908,0,0.0348995,0\n"
    "12.3,0.9986295,0,0.0523360,0\n";

// A 60 Hz HoloLens-like log whose time column is in 100 ns ticks (.NET) but named _ns: read as ns
// it would be 6 kHz with 100 times the head's 150 deg/s. Refused, with the units that give a
// plausible rate; given explicitly (--time-unit ns) it is imported with a warning.
TEST(TraceImport, AWrongTimeUnitGivingAnImplausibleRateAndSpeedIsRefused) {
    std::string text = "timestamp_ns,qw,qx,qy,qz\n";
    char b[128];
    for (int i = 0; i < 120; ++i) {  // 2 s at 60 Hz, turning at 150 deg/s about y
        const double a = 150.0 * kPi / 180.0 * i / 60.0;
        std::snprintf(b, sizeof b, "%lld,%.9f,0,%.9f,0\n",
                      638'000'000'000'000'000LL + i * 166'667LL, std::cos(a / 2), std::sin(a / 2));
        text += b;
    }
    TraceImportReport rep;
    expect_error(import_trace_text(text, "holo.csv", {}, &rep),
                 {"holo.csv: column 1 'timestamp_ns' read as ns gives a median rate of 6000 Hz",
                  "steps up to 15000 deg/s", "--time-scale 1e-7 (100 ns ticks",
                  "60 Hz, the fastest step 150 deg/s", "give the unit with --time-unit"});
    TraceImportOptions ns;
    ns.time_unit = "ns";
    Result<Trace> t = import_trace_text(text, "holo.csv", ns, &rep);
    ASSERT_TRUE(t.ok()) << t.error().message;
    ASSERT_EQ(rep.warnings.size(), 1u);
    EXPECT_TRUE(contains(rep.warnings[0], "(kept: the unit was given)")) << rep.warnings[0];
    TraceImportOptions ticks;
    ticks.time_scale_to_s = 1e-7;
    t = import_trace_text(text, "holo.csv", ticks, &rep);
    ASSERT_TRUE(t.ok()) << t.error().message;
    EXPECT_TRUE(rep.warnings.empty());
    EXPECT_NEAR(compute_trace_stats(*t).median_rate_hz, 60.0, 0.01);
}

// A recording stopped in the middle of the last row's last field (all fields there, the number
// cut, no line ending): that row is dropped with a warning naming its line; with a line ending
// the row is data, and its error stands.
TEST(TraceImport, ALastRowCutMidFieldIsDroppedWithAWarning) {
    // "12.35,0.7071068,0,0,0.7071068" cut in its last field.
    const std::string text = std::string(kTableSeconds) + "12.35,0.7071068,0,0,0.";
    TraceImportReport rep;
    Result<Trace> t = import_trace_text(text, "cut.csv", {}, &rep);
    ASSERT_TRUE(t.ok()) << t.error().message;
    EXPECT_EQ(t->samples.size(), 4u);
    EXPECT_TRUE(rep.truncated_last_row_dropped);
    EXPECT_EQ(rep.rows_read, 4u);
    ASSERT_EQ(rep.warnings.size(), 1u);
    EXPECT_TRUE(contains(rep.warnings[0], "cut.csv:6: the last row is cut short"))
        << rep.warnings[0];
    EXPECT_TRUE(contains(rep.warnings[0], "no line ending")) << rep.warnings[0];
    EXPECT_TRUE(contains(rep.warnings[0], "quaternion norm")) << rep.warnings[0];
    // Too few fields: dropped with the same warning.
    t = import_trace_text(std::string(kTableSeconds) + "12.35,0.99\n", "few.csv", {}, &rep);
    ASSERT_TRUE(t.ok());
    ASSERT_EQ(rep.warnings.size(), 1u);
    EXPECT_TRUE(contains(rep.warnings[0], "few.csv:6: the last row is cut short"))
        << rep.warnings[0];
    expect_error(import_trace_text(text + "\n", "whole.csv", {}, nullptr),
                 {"whole.csv:6:", "quaternion norm"});
}

// Column names separated by spaces over comma-separated rows.
TEST(TraceImport, AHeaderSeparatedBySpacesOverCommaRowsIsRecognised) {
    const std::string text =
        "t qw qx qy qz\n12.000,1,0,0,0\n12.0166667,0.9998477,0,0.0174524,0\n"
        "12.05,0.9993908,0,0.0348995,0\n";
    TraceImportReport rep;
    Result<Trace> t = import_trace_text(text, "sp.csv", {}, &rep);
    ASSERT_TRUE(t.ok()) << t.error().message;
    EXPECT_EQ(t->samples.size(), 3u);
    EXPECT_TRUE(contains(rep.separator, "comma"));
    bool noted = false;
    for (const std::string& n : rep.notes)
        noted |=
            contains(n, "column names from line 1 (separated by whitespace, the rows by comma");
    EXPECT_TRUE(noted);
    EXPECT_NEAR(t->samples[1].orientation.y, 0.0174524, 1e-7);
    // The time base is a comment of the trace (tracking eval compares them).
    bool base = false;
    for (const std::string& c : t->comments)
        base |= c == "time_base first_sample import sp.csv (0 = its first row)";
    EXPECT_TRUE(base);
}

TEST(TraceImport, TimeUnitsAndScalesGiveTheSameNanoseconds) {
    const int64_t want[] = {0, 16'666'700, 50'000'000, 300'000'000};
    auto times = [](const std::string& text, TraceImportOptions o) {
        TraceImportReport rep;
        Result<Trace> t = import_trace_text(text, "units.csv", o, &rep);
        EXPECT_TRUE(t.ok()) << (t.ok() ? "" : t.error().message);
        std::vector<int64_t> out;
        if (t.ok())
            for (const TraceSample& s : t->samples) out.push_back(s.time_ns);
        return out;
    };
    const std::vector<int64_t> expected(std::begin(want), std::end(want));
    EXPECT_EQ(times(kTableSeconds, {}), expected);  // 't' defaults to seconds
    TraceImportOptions ms;
    ms.time_unit = "ms";
    EXPECT_EQ(times("t,qw,qx,qy,qz\n12000,1,0,0,0\n12016.6667,1,0,0,0\n12050,1,0,0,0\n"
                    "12300,1,0,0,0\n",
                    ms),
              expected);
    EXPECT_EQ(times("time_us,qw,qx,qy,qz\n12000000,1,0,0,0\n12016666.7,1,0,0,0\n12050000,1,0,0,0\n"
                    "12300000,1,0,0,0\n",
                    {}),
              expected);
    EXPECT_EQ(times("timestamp [ns],qw,qx,qy,qz\n1700000000012000000,1,0,0,0\n"
                    "1700000000028666700,1,0,0,0\n1700000000062000000,1,0,0,0\n"
                    "1700000000312000000,1,0,0,0\n",
                    {}),
              expected);
    TraceImportOptions ticks;
    ticks.time_scale_to_s = 1e-7;  // 100 ns ticks
    EXPECT_EQ(times("t,qw,qx,qy,qz\n120000000,1,0,0,0\n120166667,1,0,0,0\n120500000,1,0,0,0\n"
                    "123000000,1,0,0,0\n",
                    ticks),
              expected);
    // Without rebasing the source's origin is kept.
    TraceImportOptions keep;
    keep.rebase_time = false;
    std::vector<int64_t> abs_times = times(kTableSeconds, keep);
    ASSERT_EQ(abs_times.size(), 4u);
    EXPECT_EQ(abs_times[0], 12 * kNsPerSecond);
    EXPECT_EQ(abs_times[3], 12'300'000'000);
    // An unknown unit is an error.
    TraceImportOptions bad;
    bad.time_unit = "min";
    expect_error(import_trace_text(kTableSeconds, "units.csv", bad, nullptr), {"time unit", "min"});
}

TEST(TraceImport, SeparatorsAreDetected) {
    auto with = [](char sep) {
        std::string s = kTableSeconds;
        for (char& c : s)
            if (c == ',') c = sep;
        return s;
    };
    const std::pair<std::string, std::string> cases[] = {
        {with(','), "comma"},
        {with('\t'), "tab"},
        {with(';'), "semicolon"},
        {with(' '), "whitespace"},
        {"t   qw qx  qy qz\n 12.0  1 0 0 0 \n12.0166667\t1 0 0 0\n", "whitespace"},
        {"\"t\", \"qw\", \"qx\", \"qy\", \"qz\"\n\"12.0\", 1, 0, 0, 0\n12.0166667, 1, 0, 0, 0\n",
         "comma"}};
    for (const auto& [text, name] : cases) {
        TraceImportReport rep;
        Result<Trace> t = import_trace_text(text, "sep.txt", {}, &rep);
        ASSERT_TRUE(t.ok()) << t.error().message << "\n" << text;
        EXPECT_EQ(rep.separator, name + " (detected)");
        ASSERT_GE(t->samples.size(), 2u);
        EXPECT_EQ(t->samples[1].time_ns, 16'666'700);
    }
    TraceImportOptions o;
    o.separator = "comma";
    expect_error(import_trace_text(with(';'), "sep.txt", o, nullptr), {"sep.txt"});
    o.separator = "semicolon";
    EXPECT_TRUE(import_trace_text(with(';'), "sep.txt", o, nullptr).ok());
}

TEST(TraceImport, XyzwOrderByIndexWithoutAHeader) {
    const std::string xyzw =
        "0.0,0,0.3826834323650898,0,0.9238795325112867,5\n"
        "0.1,0,0.7071067811865476,0,0.7071067811865476,5\n";
    TraceImportOptions o;
    o.time_column = "0";
    o.quat_columns = {"1", "2", "3", "4"};
    o.quat_order = "xyzw";
    TraceImportReport rep;
    Result<Trace> t = import_trace_text(xyzw, "xyzw.csv", o, &rep);
    ASSERT_TRUE(t.ok()) << t.error().message;
    EXPECT_EQ(rep.header_lines_skipped, 0u);
    EXPECT_NEAR(angle_between_deg(t->samples[0].orientation, yaw_quat(deg_to_rad(45))), 0, 1e-9);
    EXPECT_NEAR(angle_between_deg(t->samples[1].orientation, yaw_quat(deg_to_rad(90))), 0, 1e-9);
    EXPECT_DOUBLE_EQ(t->samples[0].orientation.w, 0.9238795325112867);
    // The same columns read as wxyz give another rotation.
    o.quat_order = "wxyz";
    Result<Trace> wrong = import_trace_text(xyzw, "xyzw.csv", o, nullptr);
    ASSERT_TRUE(wrong.ok());
    EXPECT_GT(angle_between_deg(wrong->samples[0].orientation, t->samples[0].orientation), 10.0);
    // Auto needs names.
    expect_error(import_trace_text(xyzw, "xyzw.csv", {}, nullptr), {"no time column"});
    o.quat_columns = {"1", "2", "3", "9"};
    expect_error(import_trace_text(xyzw, "xyzw.csv", o, nullptr), {"index 9", "out of range"});
}

glm::dvec3 forward_from_euler(double yaw, double pitch, double roll, bool degrees = true) {
    char text[160];
    std::snprintf(text, sizeof text, "time,yaw,pitch,roll\n0,%.17g,%.17g,%.17g\n", yaw, pitch,
                  roll);
    TraceImportOptions o;
    o.euler_degrees = degrees;
    Result<Trace> t = import_trace_text(text, "euler.csv", o, nullptr);
    EXPECT_TRUE(t.ok()) << (t.ok() ? "" : t.error().message);
    return t.ok() ? forward_of(t->samples[0].orientation) : glm::dvec3(0);
}

glm::dquat euler_quat(const std::string& yaw, const std::string& pitch, const std::string& roll) {
    TraceImportOptions o;
    o.euler_columns = {"2", "3", "4"};
    Result<Trace> t = import_trace_text(
        "time,x,a,b,c\n0,7," + yaw + "," + pitch + "," + roll + "\n", "euler.csv", o, nullptr);
    EXPECT_TRUE(t.ok()) << (t.ok() ? "" : t.error().message);
    return t.ok() ? t->samples[0].orientation : glm::dquat(1, 0, 0, 0);
}

void expect_vec_near(const glm::dvec3& a, const glm::dvec3& b) {
    EXPECT_NEAR(glm::length(a - b), 0.0, 1e-12) << a.x << "," << a.y << "," << a.z;
}

TEST(TraceImport, EulerYawPitchRollConvention) {
    // Yaw +90: forward (-Z) turns to -X (a left turn); pitch +90 looks up; roll +90 tilts the top
    // of the head (+Y) to -X.
    expect_vec_near(forward_from_euler(90, 0, 0), glm::dvec3(-1, 0, 0));
    expect_vec_near(forward_from_euler(0, 90, 0), glm::dvec3(0, 1, 0));
    expect_vec_near(forward_from_euler(0, 0, 90), glm::dvec3(0, 0, -1));
    glm::dquat roll = euler_quat("0", "0", "90");
    expect_vec_near(roll * glm::dvec3(0, 1, 0), glm::dvec3(-1, 0, 0));
    // Order: yaw applied last in the world (intrinsic yaw, pitch, roll): yaw 90 then pitch 30
    // looks up 30 degrees towards -X.
    const double c30 = std::cos(deg_to_rad(30));
    expect_vec_near(forward_from_euler(90, 30, 0), glm::dvec3(-c30, 0.5, 0));
    // Radians on request.
    expect_vec_near(forward_from_euler(kPi / 2, 0, 0, false), glm::dvec3(-1, 0, 0));
    // The full product: q = Ry(yaw) * Rx(pitch) * Rz(roll).
    glm::dquat q = euler_quat("20", "-35", "50");
    glm::dquat want = glm::angleAxis(deg_to_rad(20), glm::dvec3(0, 1, 0)) *
                      glm::angleAxis(deg_to_rad(-35), glm::dvec3(1, 0, 0)) *
                      glm::angleAxis(deg_to_rad(50), glm::dvec3(0, 0, 1));
    EXPECT_NEAR(angle_between_rad(q, want), 0.0, 1e-12);
}

TEST(TraceImport, DuplicateTimesKeepTheFirstRow) {
    const std::string text =
        "time_ms,w,x,y,z\n0,1,0,0,0\n10,1,0,0,0\n10,1,0,0,0\n10,0.9238795325112867,0,"
        "0.3826834323650898,0\n20,1,0,0,0\n";
    TraceImportReport rep;
    Result<Trace> t = import_trace_text(text, "dup.csv", {}, &rep);
    ASSERT_TRUE(t.ok()) << t.error().message;
    EXPECT_EQ(rep.rows_read, 5u);
    EXPECT_EQ(rep.samples_written, 3u);
    EXPECT_EQ(rep.duplicate_times_dropped, 2u);
    EXPECT_EQ(rep.duplicate_times_conflicting, 1u);
    EXPECT_EQ(t->samples[1].orientation, glm::dquat(1, 0, 0, 0));
}

TEST(TraceImport, ErrorsNameLineAndColumn) {
    expect_error(import_trace_text("time,w,x,y,z\n0,1,0,0,0\n0.5,1,0,0,0\n0.4,1,0,0,0\n",
                                   "back.csv", {}, nullptr),
                 {"back.csv:4:", "column 1 'time'", "time goes backwards", "0.4", "0.5", "line 3"});
    expect_error(
        import_trace_text("time,w,x,y,z\n0,1,0,0,0\n1,1,0,zz,0\n", "junk.csv", {}, nullptr),
        {"junk.csv:3:", "column 4 'y'", "'zz'"});
    expect_error(import_trace_text("time,w,x,y,z\n0,1,0,0,0\n1,1,0,0\n2,1,0,0,0\n", "count.csv", {},
                                   nullptr),
                 {"count.csv:3:", "found 4 fields, expected 5"});
    expect_error(import_trace_text("time,w,x,y,z\n0,0,0,0,0\n", "zero.csv", {}, nullptr),
                 {"zero.csv:2:", "column 2 'w'", "zero quaternion"});
    expect_error(import_trace_text("time,w,x,y,z\n0,1,0,0,0\n1,4,2,0,0\n", "far.csv", {}, nullptr),
                 {"far.csv:3:", "far from 1"});
    TraceImportOptions o;
    o.quat_columns = {"qw", "x", "y", "z"};
    expect_error(import_trace_text("time,w,x,y,z\n0,1,0,0,0\n", "name.csv", o, nullptr),
                 {"name.csv", "no column named 'qw'", "time, w, x, y, z"});
    expect_error(import_trace_text("time,a,b\n0,1,0\n", "none.csv", {}, nullptr),
                 {"none.csv", "no orientation columns"});
    expect_error(import_trace_text("hello\nworld\n", "text.csv", {}, nullptr),
                 {"text.csv", "no row of numbers"});
    expect_error(import_trace_table(temp_dir() / "missing_table.csv", {}, nullptr),
                 {"missing_table.csv"});
}

TEST(TraceImport, ExplicitHeaderLinesAllowTextInUnusedColumns) {
    const std::string text =
        "recorded 2024-05-01\nsecond preamble line\nframe\ttime\tqw\tqx\tqy\tqz\tlabel\n"
        "a\t0.0\t1\t0\t0\t0\tstart\nb\t0.1\t1\t0\t0\t0\twalk\n";
    // Auto detection finds no all-numeric row.
    expect_error(import_trace_text(text, "labels.tsv", {}, nullptr), {"labels.tsv"});
    TraceImportOptions o;
    o.header_lines = 2;
    o.separator = "tab";
    TraceImportReport rep;
    Result<Trace> t = import_trace_text(text, "labels.tsv", o, &rep);
    ASSERT_TRUE(t.ok()) << t.error().message;
    EXPECT_EQ(t->samples.size(), 2u);
    EXPECT_EQ(rep.header_lines_skipped, 3u);
    EXPECT_EQ(t->samples[1].time_ns, 100'000'000);
    // A '#' line can hold the names (as in EuRoC-style exports).
    Result<Trace> hash = import_trace_text(
        "#timestamp [us],qw,qx,qy,qz\n1000,1,0,0,0\n2000,1,0,0,0\n", "hash.csv", {}, nullptr);
    ASSERT_TRUE(hash.ok()) << hash.error().message;
    EXPECT_EQ(hash->samples[1].time_ns, 1'000'000);
    // The names line is the last one before the data with as many fields as the rows.
    TraceImportReport rep2;
    Result<Trace> units = import_trace_text(
        "time,w,x,y,z\n# units: s, none\n\n0,1,0,0,0\n1,1,0,0,0\n", "units.csv", {}, &rep2);
    ASSERT_TRUE(units.ok()) << units.error().message;
    EXPECT_EQ(rep2.header_lines_skipped, 2u);
    EXPECT_EQ(units->samples[1].time_ns, kNsPerSecond);
}

}  // namespace
TEST(TraceImport, ConvertsAZUpXForwardSourceToHmdnodeAxes) {
    // A yaw of +90 deg about the source's up axis (+Z), i.e. a left turn, and a pitch of +30 deg
    // about the source's left axis (+Y): nose down in the source's axes.
    const double h = std::sqrt(0.5);
    const double c = std::cos(deg_to_rad(15.0)), sn = std::sin(deg_to_rad(15.0));
    std::string text = "time w x y z\n0 " + std::to_string(h) + " 0 0 " + std::to_string(h) + "\n" +
                       "1 " + std::to_string(c) + " 0 " + std::to_string(sn) + " 0\n";
    TraceImportOptions o;
    o.source_frame = "z-up-x-forward";
    TraceImportReport rep;
    Result<Trace> t = import_trace_text(text, "zup.txt", o, &rep);
    ASSERT_TRUE(t.ok()) << t.error().message;
    // Left turn: forward (-Z) goes to -X, up stays +Y.
    glm::dvec3 f = t->samples[0].orientation * glm::dvec3(0, 0, -1);
    glm::dvec3 u = t->samples[0].orientation * glm::dvec3(0, 1, 0);
    EXPECT_NEAR(f.x, -1.0, 1e-6);
    EXPECT_NEAR(u.y, 1.0, 1e-6);
    // Nose down 30 deg: forward gets a -Y component of sin(30).
    f = t->samples[1].orientation * glm::dvec3(0, 0, -1);
    EXPECT_NEAR(f.y, -0.5, 1e-6);
    EXPECT_NEAR(f.z, -std::cos(deg_to_rad(30.0)), 1e-6);
    o.source_frame = "y-down";
    expect_error(import_trace_text(text, "zup.txt", o, nullptr), {"source frame", "y-down"});
}

// --- Importer: refusing wrong data --------------------------------------------------------------

// A known motion in hmdnode axes (turning left, looking up, walking forward), written as Unity
// would (left-handed, +Z forward: q -> (w, -x, -y, z), p -> (x, y, -z)), comes back exactly.
TEST(TraceImport, UnitySourceFrameRoundTripsAKnownMotion) {
    std::vector<TraceSample> truth;
    std::string text = "time,qw,qx,qy,qz,px,py,pz\n";
    char buf[256];
    for (int i = 0; i <= 100; ++i) {
        const double t = i * 0.01;
        TraceSample s;
        s.time_ns = i * 10 * kNsPerMs;
        s.orientation = glm::angleAxis(deg_to_rad(90.0 * t), glm::dvec3(0, 1, 0)) *
                        glm::angleAxis(deg_to_rad(20.0 * t), glm::dvec3(1, 0, 0));
        s.position = glm::dvec3(0.1 * t, 1.6, -1.0 * t);
        truth.push_back(s);
        const glm::dquat& q = s.orientation;
        std::snprintf(buf, sizeof buf, "%.2f,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n", t, q.w,
                      -q.x, -q.y, q.z, s.position->x, s.position->y, -s.position->z);
        text += buf;
    }
    TraceImportOptions o;
    o.source_frame = "unity";
    TraceImportReport rep;
    Result<Trace> t = import_trace_text(text, "unity.csv", o, &rep);
    ASSERT_TRUE(t.ok()) << t.error().message;
    ASSERT_EQ(t->samples.size(), truth.size());
    for (size_t i = 0; i < truth.size(); ++i) {
        EXPECT_LT(angle_between_rad(t->samples[i].orientation, truth[i].orientation), 1e-12) << i;
        EXPECT_NEAR(glm::length(*t->samples[i].position - *truth[i].position), 0.0, 1e-12) << i;
    }
    // Unity's own meaning: a positive yaw about +Y turns right (+Z forward goes to +X), walking
    // forward is +Z. In hmdnode the forward (-Z) must go to +X and the walk to -Z.
    const double h = std::sqrt(0.5);
    Result<Trace> u =
        import_trace_text("time,qw,qx,qy,qz,px,py,pz\n0,1,0,0,0,0,0,0\n1," + std::to_string(h) +
                              ",0," + std::to_string(h) + ",0,0,0,2\n",
                          "unity.csv", o, nullptr);
    ASSERT_TRUE(u.ok()) << u.error().message;
    const glm::dvec3 f = u->samples[1].orientation * glm::dvec3(0, 0, -1);
    EXPECT_NEAR(f.x, 1.0, 1e-6);
    EXPECT_NEAR(u->samples[1].position->z, -2.0, 1e-12);
}

// A HoloLens CSV in .NET ticks (100 ns) read as seconds was a 253-million-second trace: now an
// error naming the likely unit. So are sub-10-us median intervals and traces longer than a day.
TEST(TraceImport, ImplausibleTimeUnitsAreErrorsSuggestingTheUnit) {
    std::string ticks = "time,qw,qx,qy,qz\n";
    for (int i = 0; i < 50; ++i)
        ticks += std::to_string(638000000000000000LL + i * 166667LL) + ",1,0,0,0\n";
    expect_error(import_trace_text(ticks, "holo.csv", {}, nullptr),
                 {"holo.csv", "median interval of 166667 s", "--time-scale 1e-7", ".NET"});
    TraceImportOptions ok;
    ok.time_scale_to_s = 1e-7;
    EXPECT_TRUE(import_trace_text(ticks, "holo.csv", ok, nullptr).ok());

    TraceImportOptions ns;
    ns.time_unit = "ns";
    expect_error(import_trace_text("t,qw,qx,qy,qz\n0,1,0,0,0\n16.7,1,0,0,0\n33.3,1,0,0,0\n",
                                   "ms.csv", ns, nullptr),
                 {"median interval", "--time-unit ms"});
    expect_error(import_trace_text("t,qw,qx,qy,qz\n0,1,0,0,0\n0.01,1,0,0,0\n0.02,1,0,0,0\n"
                                   "0.03,1,0,0,0\n100000,1,0,0,0\n",
                                   "day.csv", {}, nullptr),
                 {"over 100000 s", "at most a day"});
}

TEST(TraceImport, NonUnitQuaternionsAndRadiansOnDegreesAreErrors) {
    expect_error(
        import_trace_text("t,qw,qx,qy,qz\n0,1,0,0,0\n0.01,1.05,0,0,0\n", "n.csv", {}, nullptr),
        {"n.csv:3:", "norm 1.05", "off by more than 0.01"});
    TraceImportReport rep;
    ASSERT_TRUE(
        import_trace_text("t,qw,qx,qy,qz\n0,1,0,0,0\n0.01,1.005,0,0,0\n", "n.csv", {}, &rep).ok());
    EXPECT_EQ(rep.non_unit_normalized, 1u);
    TraceImportOptions rad;
    rad.euler_degrees = false;
    expect_error(
        import_trace_text("t,yaw,pitch,roll\n0,0,0,0\n0.01,45,0,0\n", "e.csv", rad, nullptr),
        {"e.csv:3:", "yaw", "degrees?"});
}

// A 170 deg jump in 10 ms (17000 deg/s): reported by default, dropped or refused on request.
TEST(TraceImport, FastRotationsAreReportedDroppedOrRefused) {
    const glm::dquat far = glm::angleAxis(deg_to_rad(170.0), glm::dvec3(0, 1, 0));
    const std::string text = "t,qw,qx,qy,qz\n0,1,0,0,0\n0.01," + std::to_string(far.w) + ",0," +
                             std::to_string(far.y) + ",0\n0.02,1,0,0,0\n0.03,1,0,0,0\n";
    TraceImportReport rep;
    Result<Trace> t = import_trace_text(text, "jump.csv", {}, &rep);
    ASSERT_TRUE(t.ok()) << t.error().message;
    EXPECT_EQ(rep.fast_rotations, 2u);  // there and back
    EXPECT_EQ(t->samples.size(), 4u);
    TraceImportOptions drop;
    drop.on_fast_rotation = "drop";
    t = import_trace_text(text, "jump.csv", drop, &rep);
    ASSERT_TRUE(t.ok()) << t.error().message;
    EXPECT_EQ(rep.fast_rotations_dropped, 1u);  // the jump; the next row is near the last kept
    EXPECT_EQ(t->samples.size(), 3u);
    EXPECT_LT(rep.max_angular_speed_deg_s, 1.0);
    TraceImportOptions refuse;
    refuse.on_fast_rotation = "refuse";
    expect_error(import_trace_text(text, "jump.csv", refuse, nullptr),
                 {"jump.csv:3:", "17000 deg/s", "limit of 1500"});
}

}  // namespace hmdnode
