// Render bench: the comparison of LOD methods by render time and image quality of H. Li, S. Kim,
// "Mesh Simplification Algorithms for Rendering Performance", International Journal of
// Engineering Research and Technology 13(6), 2020 ("rendering performance improves by 25%–35%
// while maintaining the geometry"), as a tool over a replay.
//
// Phase 1 replays the trace through the node on the simulated clock with the late warp and the lens
// pass off, so each rendered frame's pose and levels are the node's own (selector, allocator,
// culling) and deterministic. Phase 2 renders frames [first, end) again on a fresh renderer, timed
// one by one: the LOD frame and, with compare_full, the same pose (same trace sample, same vsync)
// with every drawn object at level 0, read back and compared by PSNR and SSIM
// (core/src/image_quality.cpp). The two renders of a frame run back to back, so machine load
// shifts both alike; the report records the load average.
//
// Cost: one replay (its renders included) plus one or two renders and read-backs per frame, and
// O(W H) per frame for SSIM. In the code: replay_poses and frames_in_range are phase 1;
// make_bench_renderer and bench_frame (per frame) phase 2; summarize_bench the summary.
#include "hmdnode/firmware_host/render_bench.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/core/gltf.hpp"
#include "hmdnode/core/image_quality.hpp"
#include "hmdnode/core/percentile.hpp"
#include "hmdnode/core/stereo.hpp"
#include "hmdnode/core/time.hpp"
#include "hmdnode/core/trace.hpp"

namespace hmdnode {
namespace {

double load_average_1min() {
    std::ifstream f("/proc/loadavg");
    double v = std::nan("");
    f >> v;
    return v;
}

double median(std::vector<double> v) {
    return percentile(std::move(v), 0.5);
}

double min_of(const std::vector<double>& v) {
    return v.empty() ? std::nan("") : *std::min_element(v.begin(), v.end());
}

nlohmann::json num(double v) {
    return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

// The items of one frame: objects in either eye's frustum at `levels`, nearest first (as the node
// draws them).
std::vector<DrawItem> frame_items(const std::vector<SceneObject>& objects, const StereoRig& rig,
                                  const Pose& head, const std::vector<int>& levels,
                                  uint64_t* triangles, size_t* culled) {
    glm::dmat4 view[2];
    for (int e = 0; e < 2; ++e) view[e] = glm::dmat4(eye_view_matrix(rig, head, e));
    std::vector<std::pair<double, size_t>> order;
    *triangles = 0;
    *culled = 0;
    for (size_t i = 0; i < objects.size(); ++i) {
        const SceneObject& o = objects[i];
        if (!sphere_in_frustum(view[0], rig.eye[0], rig.near_m, o.bounds_center, o.bounds_radius) &&
            !sphere_in_frustum(view[1], rig.eye[1], rig.near_m, o.bounds_center, o.bounds_radius)) {
            ++*culled;
            continue;
        }
        order.emplace_back(glm::length(o.bounds_center - head.position) - o.bounds_radius, i);
        *triangles += o.levels[size_t(levels[i])].triangles;
    }
    std::sort(order.begin(), order.end());
    std::vector<DrawItem> items;
    items.reserve(order.size());
    for (const auto& [d, i] : order)
        items.push_back(
            DrawItem{objects[i].levels[size_t(levels[i])].mesh, glm::mat4(objects[i].world)});
    return items;
}

std::string frame_png_name(const char* prefix, int64_t frame) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%s_%05lld.png", prefix, (long long)frame);
    return buf;
}

}  // namespace

Result<LodMode> parse_lod_mode(const std::string& text) {
    if (text == "auto") return LodMode{LodMode::automatic, 0};
    if (text == "full") return LodMode{LodMode::full, 0};
    if (text.rfind("level=", 0) == 0) {
        const std::string n = text.substr(6);
        char* end = nullptr;
        const long v = std::strtol(n.c_str(), &end, 10);
        if (!n.empty() && *end == '\0' && v >= 0 && v <= 1000)
            return LodMode{LodMode::fixed, int(v)};
    }
    return make_error("--lod \"" + text + "\": expected auto, full or level=N (N >= 0)");
}

std::string lod_mode_name(const LodMode& mode) {
    switch (mode.kind) {
        case LodMode::automatic:
            return "auto";
        case LodMode::full:
            return "full";
        case LodMode::fixed:
            return "level=" + std::to_string(mode.level);
    }
    return "auto";
}

namespace {

Status check_render_bench_options(const RenderBenchOptions& opt) {
    if (opt.first_frame < 0 || opt.end_frame <= opt.first_frame)
        return make_error("--frames: expected FIRST:END with 0 <= FIRST < END");
    if (opt.msaa_samples != 1 && opt.msaa_samples != 4)
        return make_error("--msaa " + std::to_string(opt.msaa_samples) + ": expected 1 or 4");
    for (const auto& p : {opt.report, opt.plot})
        if (!p.empty())
            if (Status st = check_output_file(p); !st.ok()) return st.error();
    return {};
}

// Phase 1: the node's poses and levels, from the trace replayed with *ro (filled here) on the
// simulated clock, the late warp and the lens pass off. A trace of d seconds has at most
// d x rate + 1 vsyncs, so a range beyond that is refused before replaying it.
Result<ReplayResult> replay_poses(const RenderBenchOptions& opt, ReplayOptions* ro) {
    Result<Trace> trace = read_trace_csv(opt.trace);
    if (!trace.ok()) return trace.error();
    if (trace->samples.size() < 2)
        return make_error(opt.trace.string() + ": fewer than two samples");
    const double trace_s = ns_to_s(trace->samples.back().time_ns - trace->samples.front().time_ns);
    const int64_t max_frames = int64_t(std::floor(trace_s * opt.refresh_hz)) + 1;
    if (opt.first_frame >= max_frames)
        return make_error(opt.trace.string() + ": " + std::to_string(trace_s) + " s give at most " +
                          std::to_string(max_frames) + " frames at " +
                          std::to_string(opt.refresh_hz) + " Hz, none in " +
                          std::to_string(opt.first_frame) + ":" + std::to_string(opt.end_frame));
    ro->scene = opt.scene;
    ro->trace = opt.trace;
    ro->trace_data = std::make_shared<const Trace>(std::move(trace).value());
    ro->simulated_clock = true;
    ro->max_frames = opt.end_frame;
    ro->display.eye_width = opt.eye_width;
    ro->display.eye_height = opt.eye_height;
    ro->display.refresh_hz = opt.refresh_hz;
    ro->node.warp = false;
    ro->node.distortion = false;
    ro->node.lod.tolerance_px = opt.tolerance_px;
    ro->node.lod_allocator = opt.allocator;
    ro->renderer.msaa_samples = opt.msaa_samples;  // the greedy allocator learns its cost
    ro->eye_tracker = opt.eye_tracker;
    // Only the budgeted allocators' levels depend on the render cost (they learn the simulated
    // clock's model); otherwise a fixed cost that fits a period skips the calibration renders
    // (slow at full detail on a heavy scene) and makes rendered frame i the replay's vsync i.
    if (opt.allocator == LodAllocator::threshold || opt.lod.kind != LodMode::automatic)
        ro->frame_cost = FrameCostModel{};
    return run_replay(*ro);
}

// The replay's new frames in [first, end).
Result<std::vector<const FrameRecord*>> frames_in_range(const RenderBenchOptions& opt,
                                                        const ReplayResult& replay) {
    std::vector<const FrameRecord*> records;
    for (const FrameRecord& f : replay.frames)
        if (f.kind == FrameKind::new_frame && int64_t(f.frame) >= opt.first_frame &&
            int64_t(f.frame) < opt.end_frame)
            records.push_back(&f);
    if (records.empty())
        return make_error(opt.trace.string() + ": the replay rendered " +
                          std::to_string(replay.summary.new_frames) + " frames, none in " +
                          std::to_string(opt.first_frame) + ":" + std::to_string(opt.end_frame));
    return records;
}

// Phase 2's renderer (of our own, the scene uploaded) and what its frames reuse.
struct BenchRenderer {
    std::vector<SceneObject> objects;
    std::unique_ptr<Renderer> renderer;
    std::vector<int> levels, full_levels;
    StereoImage lod_image, full_image;
    bool warmed = false;
};

Status make_bench_renderer(const RenderBenchOptions& opt, BenchRenderer* b) {
    Result<Scene> scene = load_gltf(opt.scene);
    if (!scene.ok()) return scene.error();
    b->objects = flatten_objects(*scene);
    RendererConfig rc;
    rc.eye_width = opt.eye_width;
    rc.eye_height = opt.eye_height;
    rc.msaa_samples = opt.msaa_samples;
    Result<std::unique_ptr<Renderer>> renderer = create_vulkan_renderer(rc);
    if (!renderer.ok()) return renderer.error();
    b->renderer = std::move(renderer).value();
    if (Status st = b->renderer->upload(*scene); !st.ok()) return st;
    b->levels.assign(b->objects.size(), 0);
    b->full_levels.assign(b->objects.size(), 0);
    return {};
}

// The levels of `rec` in the bench's --lod mode: the node's (within each chain), the finest, or
// one level.
void bench_levels(const RenderBenchOptions& opt, const FrameRecord& rec, BenchRenderer* b) {
    for (size_t i = 0; i < b->objects.size(); ++i) {
        const int last = int(b->objects[i].levels.size()) - 1;
        switch (opt.lod.kind) {
            case LodMode::automatic:
                b->levels[i] = std::clamp(rec.levels[i], 0, last);
                break;
            case LodMode::full:
                b->levels[i] = 0;
                break;
            case LodMode::fixed:
                b->levels[i] = std::min(opt.lod.level, last);
                break;
        }
    }
}

// PSNR and SSIM (the eyes' mean) of the LOD image against the full-detail one.
Status compare_images(const BenchRenderer& b, RenderBenchFrame* f) {
    Result<double> p = psnr_db(side_by_side(b.full_image), side_by_side(b.lod_image));
    if (!p.ok()) return p.error();
    f->psnr_db = *p;
    double ss = 0.0;
    for (int e = 0; e < 2; ++e) {
        Result<double> v = ssim(b.full_image.eye[e], b.lod_image.eye[e]);
        if (!v.ok()) return v.error();
        ss += *v;
    }
    f->ssim = ss / 2.0;
    return {};
}

Status write_frame_images(const RenderBenchOptions& opt, const BenchRenderer& b, int64_t frame) {
    if (Status st =
            write_png(side_by_side(b.lod_image), opt.images_dir / frame_png_name("lod", frame));
        !st.ok())
        return st;
    if (opt.compare_full)
        if (Status st = write_png(side_by_side(b.full_image),
                                  opt.images_dir / frame_png_name("full", frame));
            !st.ok())
            return st;
    return {};
}

// Phase 2 for one rendered frame of the replay: its LOD render timed (and, with compare_full,
// the same pose with every drawn object at level 0, timed and compared), its images written
// where asked.
Result<RenderBenchFrame> bench_frame(const RenderBenchOptions& opt, const StereoRig& rig,
                                     const FrameRecord& rec, BenchRenderer* b) {
    Renderer& ren = *b->renderer;
    bench_levels(opt, rec, b);
    StereoViews views;
    for (int e = 0; e < 2; ++e) {
        views.view[e] = eye_view_matrix(rig, rec.shown_pose, e);
        views.projection[e] = eye_projection(rig.eye[e], rig.near_m, rig.far_m);
    }
    RenderBenchFrame f;
    f.frame = int64_t(rec.frame);
    f.vsync_ns = rec.render_target_vsync_ns;
    const std::vector<DrawItem> items =
        frame_items(b->objects, rig, rec.shown_pose, b->levels, &f.triangles, &f.culled);
    size_t culled = 0;
    const std::vector<DrawItem> full_items =
        opt.compare_full ? frame_items(b->objects, rig, rec.shown_pose, b->full_levels,
                                       &f.full_triangles, &culled)
                         : std::vector<DrawItem>{};
    if (!b->warmed) {  // pipelines and first-use allocations stay out of the timings
        if (auto r = ren.render(views, items, &b->lod_image); !r.ok()) return r.error();
        if (opt.compare_full)
            if (auto r = ren.render(views, full_items, &b->full_image); !r.ok()) return r.error();
        b->warmed = true;
    }
    Result<RenderStats> s = ren.render(views, items, &b->lod_image);
    if (!s.ok()) return s.error();
    f.render_ms = double(s->cpu_record_ns + s->gpu_wait_ns) * 1e-6;
    if (opt.compare_full) {
        Result<RenderStats> fs = ren.render(views, full_items, &b->full_image);
        if (!fs.ok()) return fs.error();
        f.full_render_ms = double(fs->cpu_record_ns + fs->gpu_wait_ns) * 1e-6;
        if (Status st = compare_images(*b, &f); !st.ok()) return st.error();
    }
    if (!opt.images_dir.empty() && opt.images_every > 0 &&
        (f.frame - opt.first_frame) % opt.images_every == 0)
        if (Status st = write_frame_images(opt, *b, f.frame); !st.ok()) return st.error();
    return f;
}

void summarize_bench(const RenderBenchOptions& opt, RenderBenchResult* out) {
    RenderBenchSummary& s = out->summary;
    s.frames = out->frames.size();
    std::vector<double> ms, fms, psnr, ss;
    for (const RenderBenchFrame& f : out->frames) {
        ms.push_back(f.render_ms);
        s.triangles_mean += double(f.triangles) / double(s.frames);
        if (opt.compare_full) {
            fms.push_back(f.full_render_ms);
            psnr.push_back(f.psnr_db);
            ss.push_back(f.ssim);
            s.full_triangles_mean += double(f.full_triangles) / double(s.frames);
        }
    }
    s.render_ms = percentiles(ms);
    if (opt.compare_full) {
        s.full_render_ms = percentiles(fms);
        s.time_ratio = s.full_render_ms.p50 / s.render_ms.p50;
        s.psnr_median = median(psnr);
        s.psnr_min = min_of(psnr);
        s.ssim_median = median(ss);
        s.ssim_min = min_of(ss);
    }
}

}  // namespace

Result<RenderBenchResult> run_render_bench(const RenderBenchOptions& opt) {
    if (Status st = check_render_bench_options(opt); !st.ok()) return st.error();
    RenderBenchResult out;
    out.summary.load_start = load_average_1min();
    out.cpus = int(std::thread::hardware_concurrency());

    // Phase 1: the node's poses and levels.
    ReplayOptions ro;
    Result<ReplayResult> replay = replay_poses(opt, &ro);
    if (!replay.ok()) return replay.error();
    out.gaze_source = gaze_source_summary(replay->summary);
    out.gaze_frames = replay->summary.gaze_frames;
    Result<std::vector<const FrameRecord*>> records = frames_in_range(opt, *replay);
    if (!records.ok()) return records.error();

    // Phase 2: render them again, timed, on a renderer of our own.
    BenchRenderer b;
    if (Status st = make_bench_renderer(opt, &b); !st.ok()) return st.error();
    out.device_name = b.renderer->device_name();
    if (!opt.images_dir.empty()) {
        std::error_code ec;
        std::filesystem::create_directories(opt.images_dir, ec);
        if (ec) return make_error("--images " + opt.images_dir.string() + ": " + ec.message());
    }
    const StereoRig& rig = ro.node.rig;  // no warp, no lens: the eye buffers show the rig's fov
    for (const FrameRecord* rec : *records) {
        Result<RenderBenchFrame> f = bench_frame(opt, rig, *rec, &b);
        if (!f.ok()) return f.error();
        out.frames.push_back(*f);
    }
    summarize_bench(opt, &out);
    out.summary.load_end = load_average_1min();

    if (!opt.report.empty())
        if (Status st = write_file_atomically(opt.report,
                                              render_bench_report_json(opt, out).dump(2) + "\n");
            !st.ok())
            return st.error();
    if (!opt.plot.empty())
        if (Status st = write_file_atomically(opt.plot, render_bench_svg(opt, out)); !st.ok())
            return st.error();
    return out;
}

nlohmann::json render_bench_report_json(const RenderBenchOptions& opt, const RenderBenchResult& r) {
    const RenderBenchSummary& s = r.summary;
    nlohmann::json summary = {
        {"frames", s.frames},
        {"lod",
         {{"render_ms", percentiles_json(s.render_ms)}, {"triangles_mean", s.triangles_mean}}},
    };
    if (opt.compare_full) {
        summary["full"] = {{"render_ms", percentiles_json(s.full_render_ms)},
                           {"triangles_mean", s.full_triangles_mean}};
        summary["time_ratio"] = num(s.time_ratio);
        summary["psnr_db"] = {{"median", num(s.psnr_median)}, {"min", num(s.psnr_min)}};
        summary["ssim"] = {{"median", num(s.ssim_median)}, {"min", num(s.ssim_min)}};
    }
    nlohmann::json frames = nlohmann::json::array();
    for (const RenderBenchFrame& f : r.frames) {
        nlohmann::json j = {{"frame", f.frame},
                            {"vsync_ns", f.vsync_ns},
                            {"triangles", f.triangles},
                            {"culled", f.culled},
                            {"render_ms", f.render_ms}};
        if (opt.compare_full) {
            j["full_triangles"] = f.full_triangles;
            j["full_render_ms"] = f.full_render_ms;
            j["psnr_db"] = f.psnr_db;
            j["ssim"] = f.ssim;
        }
        frames.push_back(std::move(j));
    }
    return {{"tool", "render-bench"},
            {"scene", opt.scene.string()},
            {"trace", opt.trace.string()},
            {"frames_range", {opt.first_frame, opt.end_frame}},
            {"eye_width", opt.eye_width},
            {"eye_height", opt.eye_height},
            {"refresh_hz", opt.refresh_hz},
            {"lod", lod_mode_name(opt.lod)},
            {"allocator", lod_allocator_name(opt.allocator)},
            {"lod_tolerance_px", opt.tolerance_px},
            {"msaa_samples", opt.msaa_samples},
            {"eye_tracker", eye_tracker_backend_name(opt.eye_tracker)},
            {"gaze_source", r.gaze_source},
            {"gaze_frames", r.gaze_frames},
            {"compare_full", opt.compare_full},
            {"device", r.device_name},
            {"machine",
             {{"cpus", r.cpus},
              {"load_1min_start", num(s.load_start)},
              {"load_1min_end", num(s.load_end)}}},
            {"summary", std::move(summary)},
            {"per_frame", std::move(frames)}};
}

std::string render_bench_svg(const RenderBenchOptions& opt, const RenderBenchResult& r) {
    // Two panels over the frame index: render time (LOD, full) and, with compare_full, PSNR.
    const int W = 800, panel = 220, pad = 50;
    const int panels = opt.compare_full ? 2 : 1;
    const int H = pad + panels * (panel + pad);
    std::ostringstream o;
    o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << W << "\" height=\"" << H
      << "\" font-family=\"sans-serif\" font-size=\"12\">\n"
      << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
    char buf[256];
    std::snprintf(buf, sizeof buf, "render-bench %s, %dx%d per eye, lod %s",
                  opt.scene.filename().string().c_str(), opt.eye_width, opt.eye_height,
                  lod_mode_name(opt.lod).c_str());
    o << "<text x=\"" << pad << "\" y=\"20\">" << buf << "</text>\n";
    if (r.frames.empty()) {
        o << "</svg>\n";
        return o.str();
    }
    const double f0 = double(r.frames.front().frame), f1 = double(r.frames.back().frame);
    auto xpos = [&](double f) {
        return pad + (W - 2 * pad) * (f1 > f0 ? (f - f0) / (f1 - f0) : 0.5);
    };
    auto series = [&](int top, double lo, double hi, auto value, const char* colour) {
        o << "<polyline fill=\"none\" stroke=\"" << colour << "\" stroke-width=\"1\" points=\"";
        for (const RenderBenchFrame& f : r.frames) {
            const double v = std::clamp(value(f), lo, hi);
            std::snprintf(buf, sizeof buf, "%.1f,%.1f ", xpos(double(f.frame)),
                          top + panel - panel * (v - lo) / (hi - lo));
            o << buf;
        }
        o << "\"/>\n";
    };
    auto frame_box = [&](int top, const char* label, double lo, double hi) {
        o << "<rect x=\"" << pad << "\" y=\"" << top << "\" width=\"" << W - 2 * pad
          << "\" height=\"" << panel << "\" fill=\"none\" stroke=\"#888\"/>\n";
        std::snprintf(buf, sizeof buf, "%s (%.3g to %.3g); frames %.0f to %.0f", label, lo, hi, f0,
                      f1);
        o << "<text x=\"" << pad << "\" y=\"" << top - 6 << "\">" << buf << "</text>\n";
    };
    double hi = 0.0;
    for (const RenderBenchFrame& f : r.frames) hi = std::max({hi, f.render_ms, f.full_render_ms});
    hi = hi > 0.0 ? hi * 1.05 : 1.0;
    int top = pad;
    frame_box(top, "render ms: LOD blue, full detail red", 0.0, hi);
    if (opt.compare_full)
        series(
            top, 0.0, hi, [](const RenderBenchFrame& f) { return f.full_render_ms; }, "#c33");
    series(
        top, 0.0, hi, [](const RenderBenchFrame& f) { return f.render_ms; }, "#33c");
    if (opt.compare_full) {
        top += panel + pad;
        double plo = 1e9, phi = 0.0;
        for (const RenderBenchFrame& f : r.frames) {
            plo = std::min(plo, f.psnr_db);
            phi = std::max(phi, f.psnr_db);
        }
        plo = std::floor(plo - 1.0);
        phi = std::ceil(phi + 1.0);
        frame_box(top, "PSNR dB of LOD against full detail", plo, phi);
        series(
            top, plo, phi, [](const RenderBenchFrame& f) { return f.psnr_db; }, "#393");
    }
    o << "</svg>\n";
    return o.str();
}

std::string render_bench_table(const RenderBenchOptions& opt, const RenderBenchResult& r) {
    const RenderBenchSummary& s = r.summary;
    std::ostringstream o;
    char buf[256];
    std::snprintf(buf, sizeof buf, "frames            %zu (%lld:%lld), %dx%d per eye, lod %s\n",
                  s.frames, (long long)opt.first_frame, (long long)opt.end_frame, opt.eye_width,
                  opt.eye_height, lod_mode_name(opt.lod).c_str());
    o << buf;
    std::snprintf(buf, sizeof buf,
                  "LOD   render ms   p50 %.2f  p95 %.2f  max %.2f  triangles %.0f\n",
                  s.render_ms.p50, s.render_ms.p95, s.render_ms.max, s.triangles_mean);
    o << buf;
    if (opt.compare_full) {
        std::snprintf(buf, sizeof buf,
                      "full  render ms   p50 %.2f  p95 %.2f  max %.2f  triangles %.0f\n",
                      s.full_render_ms.p50, s.full_render_ms.p95, s.full_render_ms.max,
                      s.full_triangles_mean);
        o << buf;
        std::snprintf(buf, sizeof buf,
                      "time ratio        %.2f (full / LOD, p50)\nPSNR dB           median %.2f  "
                      "min %.2f\nSSIM              median %.4f  min %.4f\n",
                      s.time_ratio, s.psnr_median, s.psnr_min, s.ssim_median, s.ssim_min);
        o << buf;
    }
    std::snprintf(buf, sizeof buf, "machine           %s, %d cpus, load %.2f -> %.2f\n",
                  r.device_name.c_str(), r.cpus, s.load_start, s.load_end);
    o << buf;
    return o.str();
}

}  // namespace hmdnode
