// The scene's lightmap atlas: segments every chosen primitive into charts (uv_charts.cpp),
// parameterises each chart (planar projection or LSCM, lscm.cpp; a chart whose map flips a triangle
// or overlaps itself is cut in two across its longest axis and each part redone), turns it to its
// minimum-area bounding rectangle (H. Freeman, R. Shapira, "Determining the minimum-area encasing
// rectangle for an arbitrary closed curve", Communications of the ACM 18(7), 1975: a side lies on a
// hull edge), scales it to texels (surface area x texels_per_metre^2), and packs the chart
// rectangles with the skyline packer of stb_rect_pack (J. Jylanki, "A Thousand Ways to Pack the
// Bin", online report, 2010: SKYLINE-BL-WM) into the atlas of least area (power-of-two width,
// height cropped) that holds them, or into as many max-size atlases as needed.
// Cost: O(C log C) per packing attempt for C charts, log2(max/16) attempts per atlas; O(F log F)
// to rewrite the primitives; memory O(C) plus O(V + F) for the rewritten primitives and a copy of
// the scene (so that an error leaves the caller's scene unchanged).
// Departures: charts are packed as axis-aligned rectangles (turned so the longer side is
// horizontal; no nesting of charts in each other's holes, as xatlas does); an atlas is cropped to
// the rectangle its charts use; the chart cut is a median split, not a re-segmentation.
#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdio>
#include <map>
#include <numeric>
#include <string>
#include <unordered_map>

#include <stb_rect_pack.h>

#include "hmdnode/bake/uv_atlas.hpp"
#include "world_lights.hpp"

namespace hmdnode {

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Chart {
    int mesh = -1, prim = -1;
    std::vector<uint32_t> faces;                   // face indices of the primitive
    std::vector<uint32_t> local_of;                // chart-local vertex -> welded vertex id
    std::unordered_map<uint32_t, uint32_t> local;  // welded vertex id -> chart-local vertex
    std::vector<glm::dvec2> uv;        // per chart-local vertex, texels, min corner at (0, 0)
    double width = 0.0, height = 0.0;  // extent in texels
    int rect_w = 0, rect_h = 0;        // packed rectangle with padding
    int atlas = -1, x = 0, y = 0;      // chart origin (texels) in its atlas
    double area_texels = 0.0;
};

// Edge-connected components of a set of faces (welded ids).
std::vector<std::vector<uint32_t>> components(const std::vector<uint32_t>& faces,
                                              const std::vector<uint32_t>& indices,
                                              const std::vector<uint32_t>& weld) {
    std::map<uint64_t, std::vector<size_t>> edges;
    for (size_t i = 0; i < faces.size(); ++i)
        for (int e = 0; e < 3; ++e) {
            uint32_t a = weld[indices[3 * faces[i] + e]],
                     b = weld[indices[3 * faces[i] + (e + 1) % 3]];
            if (a == b) continue;
            if (a > b) std::swap(a, b);
            edges[(uint64_t(a) << 32) | b].push_back(i);
        }
    std::vector<size_t> parent(faces.size());
    std::iota(parent.begin(), parent.end(), size_t(0));
    auto find = [&](size_t x) {
        while (parent[x] != x) x = parent[x] = parent[parent[x]];
        return x;
    };
    for (auto& [k, list] : edges)
        for (size_t j = 1; j < list.size(); ++j) parent[find(list[j])] = find(list[0]);
    std::map<size_t, std::vector<uint32_t>> groups;
    for (size_t i = 0; i < faces.size(); ++i) groups[find(i)].push_back(faces[i]);
    std::vector<std::vector<uint32_t>> out;
    for (auto& [k, g] : groups) out.push_back(std::move(g));
    assert(!faces.empty() == !out.empty());  // a partition of the faces
    return out;
}

struct ParamContext {
    const Primitive* prim;
    const std::vector<uint32_t>* weld;
    double cos_planar;
    AtlasReport* report;
    double distortion_sum = 0.0, distortion_area = 0.0;
};

ChartMesh chart_mesh(const ParamContext& ctx, const std::vector<uint32_t>& faces,
                     std::vector<uint32_t>& local_of) {
    ChartMesh m;
    std::map<uint32_t, uint32_t> local;
    for (uint32_t f : faces)
        for (int k = 0; k < 3; ++k) {
            const uint32_t w = (*ctx.weld)[ctx.prim->indices[3 * f + k]];
            auto [it, inserted] = local.emplace(w, uint32_t(m.positions.size()));
            if (inserted) {
                m.positions.push_back(glm::dvec3(ctx.prim->positions[w]));
                local_of.push_back(w);
            }
            m.indices.push_back(it->second);
        }
    // The chart's own small mesh: 3 local indices per face, each a local vertex.
    assert(m.indices.size() == 3 * faces.size() && local_of.size() == m.positions.size());
    return m;
}

// Parameterises a connected set of faces into one or more charts (metres, uv area = 3D area).
void parameterise(ParamContext& ctx, const std::vector<uint32_t>& faces, int depth,
                  std::vector<Chart>& out) {
    assert(!faces.empty() && depth >= 0 && depth <= 40);
    Chart chart;
    ChartMesh m = chart_mesh(ctx, faces, chart.local_of);
    const size_t nf = faces.size();
    // Near-planar?
    glm::dvec3 sum(0.0);
    std::vector<glm::dvec3> normals(nf);
    for (size_t f = 0; f < nf; ++f) {
        const uint32_t* t = &m.indices[3 * f];
        normals[f] = glm::cross(m.positions[t[1]] - m.positions[t[0]],
                                m.positions[t[2]] - m.positions[t[0]]);
        sum += normals[f];
    }
    bool planar = true;
    const double ls = glm::length(sum);
    for (const glm::dvec3& n : normals) {
        const double ln = glm::length(n);
        if (ln > 0.0 && !(glm::dot(n, sum) >= ctx.cos_planar * ln * ls)) planar = false;
    }
    if (!(ls > 0.0)) planar = true;  // all degenerate
    std::vector<glm::dvec2> uv;
    bool ok = false;
    if (planar) {
        uv = planar_parameterise(m);
    } else if (auto r = lscm_parameterise(m); r.ok()) {
        uv = std::move(*r);
    }
    if (!uv.empty()) {
        const ParamQuality q = measure_parameterisation(m, uv);
        ok = q.flipped == 0 && q.overlapping == 0;
    }
    if (ok) {
        (planar ? ctx.report->planar_charts : ctx.report->lscm_charts)++;
    } else if (nf >= 2 && depth < 40) {
        // Cut across the longest axis of the bounding box at the median face centroid.
        ctx.report->split_charts++;
        glm::dvec3 lo(1e300), hi(-1e300);
        for (const auto& p : m.positions) lo = glm::min(lo, p), hi = glm::max(hi, p);
        const glm::dvec3 ext = hi - lo;
        const int axis = ext.x >= ext.y && ext.x >= ext.z ? 0 : (ext.y >= ext.z ? 1 : 2);
        std::vector<std::pair<double, uint32_t>> keyed(nf);
        for (size_t f = 0; f < nf; ++f) {
            const uint32_t* t = &m.indices[3 * f];
            keyed[f] = {m.positions[t[0]][axis] + m.positions[t[1]][axis] + m.positions[t[2]][axis],
                        faces[f]};
        }
        std::sort(keyed.begin(), keyed.end());
        std::vector<uint32_t> half[2];
        for (size_t f = 0; f < nf; ++f) half[f < nf / 2 ? 0 : 1].push_back(keyed[f].second);
        // Both halves are smaller, so the recursion ends (at single triangles at the latest).
        assert(!half[0].empty() && !half[1].empty());
        for (auto& h : half)
            for (auto& c : components(h, ctx.prim->indices, *ctx.weld))
                parameterise(ctx, c, depth + 1, out);
        return;
    } else {
        uv = planar_parameterise(m);  // a single triangle: always valid
        ctx.report->planar_charts++;
    }
    // Rescale planar projections to the 3D area too (near-planar charts lose cos(angle)).
    ParamQuality q = measure_parameterisation(m, uv);
    if (q.area_ratio > 0.0 && std::abs(q.area_ratio - 1.0) > 1e-12) {
        const double s = 1.0 / std::sqrt(q.area_ratio);
        for (auto& w : uv) w *= s;
    }
    double area3 = 0.0;
    for (const glm::dvec3& n : normals) area3 += 0.5 * glm::length(n);
    ctx.distortion_sum += q.mean_conformal * area3;
    ctx.distortion_area += area3;
    ctx.report->max_area_distortion =
        std::max(ctx.report->max_area_distortion, q.max_area_distortion);
    // Minimum-area bounding rectangle (one of its sides is collinear with a convex-hull edge,
    // Freeman & Shapira 1975), then the longer side along x (the skyline packer prefers it).
    {
        std::vector<glm::dvec2> pts = uv;
        std::sort(pts.begin(), pts.end(), [](const glm::dvec2& a, const glm::dvec2& b) {
            return a.x < b.x || (a.x == b.x && a.y < b.y);
        });
        auto cross = [](const glm::dvec2& o, const glm::dvec2& a, const glm::dvec2& b) {
            return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
        };
        std::vector<glm::dvec2> hull(2 * pts.size());
        size_t k = 0;
        for (size_t i = 0; i < pts.size(); ++i) {  // Andrew's monotone chain
            while (k >= 2 && cross(hull[k - 2], hull[k - 1], pts[i]) <= 0.0) --k;
            hull[k++] = pts[i];
        }
        for (size_t i = pts.size() - 1, t = k + 1; i-- > 0;) {
            while (k >= t && cross(hull[k - 2], hull[k - 1], pts[i]) <= 0.0) --k;
            hull[k++] = pts[i];
        }
        assert(k <= 2 * pts.size());
        hull.resize(k > 1 ? k - 1 : k);
        double best_area = 1e300, best_c = 1.0, best_s = 0.0;
        for (size_t i = 0; i < hull.size(); ++i) {
            const glm::dvec2 e = hull[(i + 1) % hull.size()] - hull[i];
            const double len = glm::length(e);
            if (!(len > 0.0)) continue;
            const double c = e.x / len, sn = e.y / len;
            glm::dvec2 lo(1e300), hi(-1e300);
            for (const auto& h : hull) {
                const glm::dvec2 r(c * h.x + sn * h.y, -sn * h.x + c * h.y);
                lo = glm::min(lo, r), hi = glm::max(hi, r);
            }
            const double area = (hi.x - lo.x) * (hi.y - lo.y);
            if (area < best_area) best_area = area, best_c = c, best_s = sn;
        }
        glm::dvec2 lo(1e300), hi(-1e300);
        for (auto& w : uv) {
            w = {best_c * w.x + best_s * w.y, -best_s * w.x + best_c * w.y};
            lo = glm::min(lo, w), hi = glm::max(hi, w);
        }
        if (hi.y - lo.y > hi.x - lo.x)  // rotate by 90 degrees (orientation preserved)
            for (auto& w : uv) w = {w.y, -w.x};
    }
    assert(uv.size() == chart.local_of.size());  // one uv per chart vertex
    chart.faces = faces;
    for (size_t i = 0; i < chart.local_of.size(); ++i) chart.local[chart.local_of[i]] = uint32_t(i);
    chart.uv = std::move(uv);
    chart.area_texels = area3;  // metres^2 for now
    out.push_back(std::move(chart));
}

// Packs rects into one width x height target; returns how many were packed.
size_t pack(std::vector<stbrp_rect>& rects, int width, int height) {
    assert(width > 0 && height > 0);
    stbrp_context ctx;
    std::vector<stbrp_node> nodes(size_t(width) + 1);
    stbrp_init_target(&ctx, width, height, nodes.data(), int(nodes.size()));
    stbrp_pack_rects(&ctx, rects.data(), int(rects.size()));
    size_t n = 0;
    for (const auto& r : rects) {
        n += r.was_packed ? 1 : 0;
        // A packed rectangle lies inside the target.
        assert(!r.was_packed ||
               (r.x >= 0 && r.y >= 0 && r.x + r.w <= width && r.y + r.h <= height));
    }
    return n;
}

bool finite(const glm::vec3& p) {
    return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
}

}  // namespace

namespace {
Result<AtlasReport> build_uv_atlas_in(Scene& scene, const AtlasOptions& options);
}

Result<AtlasReport> build_uv_atlas(Scene& scene, const AtlasOptions& options) {
    // Work on a copy so that an error leaves the caller's scene unchanged.
    Scene work = scene;
    Result<AtlasReport> r = build_uv_atlas_in(work, options);
    if (r.ok()) scene = std::move(work);
    return r;
}

namespace {

Status check_atlas_options(const AtlasOptions& options) {
    if (!(options.texels_per_metre > 0.0) || !std::isfinite(options.texels_per_metre))
        return make_error("uv atlas: texels_per_metre must be > 0");
    if (options.padding_texels < 2) return make_error("uv atlas: padding_texels must be >= 2");
    if (options.max_atlas_size < 16) return make_error("uv atlas: max_atlas_size must be >= 16");
    if (!(options.chart_angle_deg > 0.0 && options.chart_angle_deg <= 180.0) ||
        !(options.planar_angle_deg >= 0.0 && options.planar_angle_deg < 90.0))
        return make_error(
            "uv atlas: chart_angle_deg must be in (0, 180], planar_angle_deg in "
            "[0, 90)");
    return {};
}

// One atlased (mesh, primitive): its charts are charts[first_chart, end_chart).
struct Job {
    int mesh, prim;
    size_t first_chart, end_chart;
};

// Charts too large for the atlas: all are counted, the largest (in texels: the one that needs
// the lowest density) is named with the density at which it fits, so that one rerun at that
// density fits them all.
struct TooLarge {
    size_t count = 0;
    double largest_extent = 0.0;
    std::string largest_message;
};

// The passes of build_uv_atlas_in over one scene, in order, and what they hand on.
class AtlasBuilder {
  public:
    AtlasBuilder(Scene& scene, const AtlasOptions& options)
        : scene_(scene), options_(options), origin_(scene.meshes.size()) {
        std::iota(origin_.begin(), origin_.end(), 0);
    }

    Result<AtlasReport> run() {
        if (options_.unshare_instances) unshare_instances();
        const std::vector<double> mesh_scale = world_scales();
        if (Status s = segment_and_parameterise(mesh_scale); !s.ok()) return s.error();
        if (Status s = pack_charts(); !s.ok()) return s.error();
        find_exclusive_materials();
        // Rewrite the primitives: one output primitive per atlas its charts use.
        for (size_t j = 0; j < jobs_.size(); ++j) rewrite_primitive(j);
        return report_;
    }

  private:
    bool chosen(int m, int p) const {
        return !options_.lightmapped || options_.lightmapped(origin_[size_t(m)], p);
    }

    // Instances: a mesh placed by several nodes gets one copy per extra node, so that each
    // instance has its own lightmap texels.
    void unshare_instances() {
        std::vector<char> claimed(scene_.meshes.size(), 0);
        for (Node& node : scene_.nodes) {
            const int m = node.mesh;
            if (m < 0 || size_t(m) >= claimed.size()) continue;
            if (!claimed[size_t(m)]) {
                claimed[size_t(m)] = 1;
                continue;
            }
            bool atlased = false;
            for (size_t pi = 0; pi < scene_.meshes[size_t(m)].primitives.size(); ++pi) {
                const Primitive& prim = scene_.meshes[size_t(m)].primitives[pi];
                atlased |= chosen(m, int(pi)) && prim.uv1.empty() && !prim.indices.empty();
            }
            if (!atlased) continue;
            Mesh copy = scene_.meshes[size_t(m)];
            copy.name += "_instance" + std::to_string(++report_.unshared_instances);
            node.mesh = int(scene_.meshes.size());
            scene_.meshes.push_back(std::move(copy));
            origin_.push_back(origin_[size_t(m)]);
        }
    }

    // World scale per mesh: the largest axis scale among the nodes using it.
    std::vector<double> world_scales() const {
        std::vector<double> mesh_scale(scene_.meshes.size(), 0.0);
        const std::vector<glm::dmat4> world = detail::node_world_matrices(scene_);
        for (size_t i = 0; i < scene_.nodes.size(); ++i) {
            const int m = scene_.nodes[i].mesh;
            if (m < 0 || size_t(m) >= scene_.meshes.size()) continue;
            const glm::dmat4& w = world[i];
            const double s = std::max({glm::length(glm::dvec3(w[0])), glm::length(glm::dvec3(w[1])),
                                       glm::length(glm::dvec3(w[2]))});
            mesh_scale[size_t(m)] = std::max(mesh_scale[size_t(m)], s);
        }
        for (double& s : mesh_scale)
            if (!(s > 0.0) || !std::isfinite(s)) s = 1.0;
        return mesh_scale;
    }

    // Segment and parameterise.
    Status segment_and_parameterise(const std::vector<double>& mesh_scale) {
        const double cos_planar = std::cos(options_.planar_angle_deg * kPi / 180.0);
        TooLarge too_large;
        for (size_t mi = 0; mi < scene_.meshes.size(); ++mi) {
            const Mesh& mesh = scene_.meshes[mi];
            for (size_t pi = 0; pi < mesh.primitives.size(); ++pi) {
                const Primitive& prim = mesh.primitives[pi];
                if (!chosen(int(mi), int(pi)) || prim.indices.empty()) continue;
                if (!prim.uv1.empty()) {
                    report_.kept_primitives++;
                    const int mat = prim.material;
                    if (mat < 0 || size_t(mat) >= scene_.materials.size() ||
                        scene_.materials[size_t(mat)].lightmap.texture < 0)
                        report_.kept_without_lightmap.push_back("'" + mesh.name + "'/" +
                                                                std::to_string(pi));
                    continue;
                }
                if (Status s = check_primitive(mesh, pi); !s.ok()) return s;
                parameterise_primitive(mi, pi, cos_planar);
                const double texels = mesh_scale[mi] * options_.texels_per_metre;
                scale_charts(jobs_.back(), mesh.name, texels, too_large);
            }
        }
        if (too_large.count == 1) return make_error("uv atlas: " + too_large.largest_message);
        if (too_large.count > 1)
            return make_error("uv atlas: " + std::to_string(too_large.count) +
                              " charts do not fit; the largest, " + too_large.largest_message);
        report_.charts = charts_.size();
        report_.primitives = jobs_.size();
        report_.mean_conformal_distortion =
            distortion_area_ > 0.0 ? distortion_sum_ / distortion_area_ : 1.0;
        return {};
    }

    static Status check_primitive(const Mesh& mesh, size_t pi) {
        const Primitive& prim = mesh.primitives[pi];
        for (size_t v = 0; v < prim.positions.size(); ++v)
            if (!finite(prim.positions[v]))
                return make_error("uv atlas: mesh '" + mesh.name + "' primitive " +
                                  std::to_string(pi) + ": vertex " + std::to_string(v) +
                                  " has a non-finite position");
        for (uint32_t i : prim.indices)
            if (i >= prim.positions.size())
                return make_error("uv atlas: mesh '" + mesh.name + "' primitive " +
                                  std::to_string(pi) + ": index " + std::to_string(i) +
                                  " out of range");
        return {};
    }

    // The charts of one primitive, appended to charts_ (in metres), and its job.
    void parameterise_primitive(size_t mi, size_t pi, double cos_planar) {
        const Primitive& prim = scene_.meshes[mi].primitives[pi];
        welds_.push_back(weld_positions(prim.positions));
        int count = 0;
        const std::vector<int> seg =
            segment_charts(prim.positions, prim.indices, options_.chart_angle_deg,
                           options_.max_chart_faces, &count);
        std::vector<std::vector<uint32_t>> groups(static_cast<size_t>(count));
        for (size_t f = 0; f < seg.size(); ++f) groups[size_t(seg[f])].push_back(uint32_t(f));
        ParamContext ctx{&prim, &welds_.back(), cos_planar, &report_};
        Job job{int(mi), int(pi), charts_.size(), 0};
        for (const auto& g : groups) parameterise(ctx, g, 0, charts_);
        job.end_chart = charts_.size();
        jobs_.push_back(job);
        distortion_sum_ += ctx.distortion_sum;
        distortion_area_ += ctx.distortion_area;
    }

    // A job's charts scaled to texels (min corner at 0), with their padded rectangles.
    void scale_charts(const Job& job, const std::string& mesh_name, double texels,
                      TooLarge& too_large) {
        for (size_t c = job.first_chart; c < job.end_chart; ++c) {
            Chart& ch = charts_[c];
            ch.mesh = job.mesh, ch.prim = job.prim;
            glm::dvec2 lo(1e300), hi(-1e300);
            for (auto& w : ch.uv) {
                w *= texels;
                lo = glm::min(lo, w), hi = glm::max(hi, w);
            }
            for (auto& w : ch.uv) w -= lo;
            ch.width = hi.x - lo.x, ch.height = hi.y - lo.y;
            ch.area_texels *= texels * texels;
            ch.rect_w = std::max(1, int(std::ceil(ch.width - 1e-9))) + options_.padding_texels;
            ch.rect_h = std::max(1, int(std::ceil(ch.height - 1e-9))) + options_.padding_texels;
            if (ch.rect_w > options_.max_atlas_size || ch.rect_h > options_.max_atlas_size) {
                const double extent = std::max(ch.width, ch.height);
                ++too_large.count;
                if (extent <= too_large.largest_extent) continue;
                too_large.largest_extent = extent;
                const double fit = options_.texels_per_metre *
                                   double(options_.max_atlas_size - options_.padding_texels - 1) /
                                   extent;
                char buf[160];
                std::snprintf(buf, sizeof buf,
                              "%.0f x %.0f texels (%.3g x %.3g m) at %g texels/m does not fit "
                              "a %d-texel atlas; use at most %.3g texels per metre",
                              std::ceil(ch.width), std::ceil(ch.height), ch.width / texels,
                              ch.height / texels, options_.texels_per_metre,
                              options_.max_atlas_size, std::floor(fit * 1000.0) / 1000.0);
                too_large.largest_message = "mesh '" + mesh_name + "' primitive " +
                                            std::to_string(job.prim) + ": a chart of " + buf;
            }
        }
    }

    // Pack: the charts of one primitive are kept consecutive in the rect list; stb sorts by
    // height internally, so a primitive may still straddle atlases (handled below).
    Status pack_charts() {
        std::vector<size_t> remaining(charts_.size());
        std::iota(remaining.begin(), remaining.end(), size_t(0));
        while (!remaining.empty()) {
            if (Status s = pack_atlas(remaining); !s.ok()) return s;
        }
        for (const Chart& ch : charts_) report_.chart_texels += ch.area_texels;
        report_.atlases = report_.textures.size();
        report_.utilisation =
            report_.atlas_texels > 0 ? report_.chart_texels / double(report_.atlas_texels) : 0.0;
        return {};
    }

    std::vector<stbrp_rect> make_rects(const std::vector<size_t>& remaining, bool standing) const {
        std::vector<stbrp_rect> rects(remaining.size());
        for (size_t i = 0; i < remaining.size(); ++i) {
            rects[i].id = int(i);
            rects[i].w = standing ? charts_[remaining[i]].rect_h : charts_[remaining[i]].rect_w;
            rects[i].h = standing ? charts_[remaining[i]].rect_w : charts_[remaining[i]].rect_h;
        }
        return rects;
    }

    // The smallest atlas (area after cropping) that holds everything, trying power-of-two
    // widths at the full height and the charts lying (longer side along x) or standing;
    // else a full max x max atlas of lying charts and the rest in the next one.
    // Returns the width (-1: none holds everything) and whether the charts stand.
    std::pair<int, bool> choose_atlas_shape(const std::vector<size_t>& remaining) const {
        double need = 0.0;
        for (size_t i : remaining) need += double(charts_[i].rect_w) * charts_[i].rect_h;
        const int max_size = options_.max_atlas_size;
        double best_area = 1e300;
        int best_width = -1;
        bool best_standing = false;
        for (bool standing : {false, true}) {
            const std::vector<stbrp_rect> rects = make_rects(remaining, standing);
            for (int w = 16;; w *= 2) {
                const int width = std::min(w, max_size);
                if (double(width) * max_size >= need) {
                    std::vector<stbrp_rect> trial = rects;
                    if (pack(trial, width, max_size) == trial.size()) {
                        int uw = 0, uh = 0;
                        for (const auto& r : trial)
                            uw = std::max(uw, r.x + r.w), uh = std::max(uh, r.y + r.h);
                        const double area =
                            double(uw) * uh + 1e-3 * std::abs(uw - uh);  // prefer square
                        if (area < best_area)
                            best_area = area, best_width = width, best_standing = standing;
                    }
                }
                if (width == max_size) break;
            }
        }
        return {best_width, best_standing};
    }

    // One atlas of the remaining charts; `remaining` becomes those it does not hold.
    Status pack_atlas(std::vector<size_t>& remaining) {
        const int max_size = options_.max_atlas_size;
        const int half_pad = options_.padding_texels / 2;
        const auto [best_width, best_standing] = choose_atlas_shape(remaining);
        std::vector<stbrp_rect> rects = make_rects(remaining, best_standing);
        size_t packed = pack(rects, best_width > 0 ? best_width : max_size, max_size);
        if (best_standing)  // turn the placed charts by 90 degrees (orientation preserved)
            for (const auto& r : rects) {
                Chart& ch = charts_[remaining[size_t(r.id)]];
                for (auto& w : ch.uv) w = {ch.height - w.y, w.x};
                std::swap(ch.width, ch.height);
                std::swap(ch.rect_w, ch.rect_h);
            }
        if (packed == 0) return make_error("uv atlas: packing made no progress");  // unreachable
        const int atlas = int(report_.textures.size());
        int used_w = 0, used_h = 0;
        std::vector<size_t> rest;
        for (const auto& r : rects) {
            Chart& ch = charts_[remaining[size_t(r.id)]];
            if (!r.was_packed) {
                rest.push_back(remaining[size_t(r.id)]);
                continue;
            }
            ch.atlas = atlas;
            ch.x = r.x + half_pad;
            ch.y = r.y + half_pad;
            used_w = std::max(used_w, int(r.x + r.w));
            used_h = std::max(used_h, int(r.y + r.h));
        }
        Texture tex;
        tex.name = "lightmap_" + std::to_string(atlas);
        tex.width = std::max(used_w, 4);
        tex.height = std::max(used_h, 4);
        tex.rgba8.assign(size_t(tex.width) * size_t(tex.height) * 4, 0);
        for (size_t i = 3; i < tex.rgba8.size(); i += 4) tex.rgba8[i] = 255;
        report_.textures.push_back(int(scene_.textures.size()));
        report_.widths.push_back(tex.width);
        report_.heights.push_back(tex.height);
        report_.atlas_texels += size_t(tex.width) * size_t(tex.height);
        scene_.textures.push_back(std::move(tex));
        remaining = std::move(rest);
        return {};
    }

    // Materials: a material may be lightmapped in place only when every primitive using it is
    // being atlased and it has no lightmap yet; the first atlas takes it, others get clones.
    void find_exclusive_materials() {
        exclusive_.assign(scene_.materials.size(), 1);
        for (size_t mi = 0; mi < scene_.meshes.size(); ++mi)
            for (size_t pi = 0; pi < scene_.meshes[mi].primitives.size(); ++pi) {
                const Primitive& prim = scene_.meshes[mi].primitives[pi];
                const bool atlased =
                    chosen(int(mi), int(pi)) && prim.uv1.empty() && !prim.indices.empty();
                if (!atlased && prim.material >= 0 && size_t(prim.material) < exclusive_.size())
                    exclusive_[size_t(prim.material)] = 0;
            }
        for (size_t m = 0; m < scene_.materials.size(); ++m)
            if (scene_.materials[m].lightmap.texture >= 0) exclusive_[m] = 0;
    }

    int material_of(int mat, int atlas) {
        auto it = material_for_.find({mat, atlas});
        if (it != material_for_.end()) return it->second;
        int out;
        if (mat >= 0 && size_t(mat) < scene_.materials.size() && exclusive_[size_t(mat)]) {
            out = mat;
            exclusive_[size_t(mat)] = 0;
        } else {
            Material copy;
            if (mat >= 0 && size_t(mat) < scene_.materials.size()) {
                copy = scene_.materials[size_t(mat)];
                copy.name += "_lightmap" + std::to_string(atlas);
            } else {
                copy.name = "lightmapped_default_" + std::to_string(atlas);
            }
            out = int(scene_.materials.size());
            scene_.materials.push_back(copy);
        }
        Lightmap& lm = scene_.materials[size_t(out)].lightmap;
        lm.texture = report_.textures[size_t(atlas)];
        lm.tex_coord = 1;
        lm.intensity = 1.0f;
        material_for_[{mat, atlas}] = out;
        return out;
    }

    // Job j's primitive as one output primitive per atlas its charts use.
    void rewrite_primitive(size_t j) {
        const Job& job = jobs_[j];
        Mesh& mesh = scene_.meshes[size_t(job.mesh)];
        const Primitive src = mesh.primitives[size_t(job.prim)];
        std::map<int, Primitive> per_atlas;
        std::map<int, std::map<std::pair<uint32_t, size_t>, uint32_t>> vertex_maps;
        std::vector<int> chart_of_face(src.triangle_count(), -1);
        for (size_t c = job.first_chart; c < job.end_chart; ++c)
            for (uint32_t f : charts_[c].faces) chart_of_face[f] = int(c);
        for (size_t f = 0; f < src.triangle_count(); ++f) {
            const Chart& ch = charts_[size_t(chart_of_face[f])];
            Primitive& dst = per_atlas[ch.atlas];
            auto& vmap = vertex_maps[ch.atlas];
            const int atlas = ch.atlas;
            const double W = report_.widths[size_t(atlas)], H = report_.heights[size_t(atlas)];
            for (int k = 0; k < 3; ++k) {
                const uint32_t v = src.indices[3 * f + k];
                const auto key = std::make_pair(v, size_t(chart_of_face[f]));
                auto it = vmap.find(key);
                if (it == vmap.end()) {
                    const uint32_t w = welds_[j][v];
                    const glm::dvec2 t = ch.uv[ch.local.at(w)] + glm::dvec2(ch.x, ch.y);
                    const uint32_t nv = uint32_t(dst.positions.size());
                    dst.positions.push_back(src.positions[v]);
                    if (!src.normals.empty()) dst.normals.push_back(src.normals[v]);
                    if (!src.uv0.empty()) dst.uv0.push_back(src.uv0[v]);
                    if (!src.colors.empty()) dst.colors.push_back(src.colors[v]);
                    if (!src.light.empty()) dst.light.push_back(src.light[v]);
                    dst.uv1.push_back(glm::vec2(float(t.x / W), float(t.y / H)));
                    it = vmap.emplace(key, nv).first;
                }
                dst.indices.push_back(it->second);
            }
        }
        report_.vertices_before += src.positions.size();
        bool first = true;
        for (auto& [atlas, dst] : per_atlas) {
            dst.material = material_of(src.material, atlas);
            report_.vertices_after += dst.positions.size();
            if (first) {
                mesh.primitives[size_t(job.prim)] = std::move(dst);
                first = false;
            } else {
                mesh.primitives.push_back(std::move(dst));
            }
        }
    }

    Scene& scene_;
    const AtlasOptions& options_;
    AtlasReport report_;
    // origin_[m]: the mesh index the caller knows (clones made below map to their original).
    std::vector<int> origin_;
    std::vector<Chart> charts_;
    std::vector<std::vector<uint32_t>> welds_;  // per (mesh, prim) job
    std::vector<Job> jobs_;
    double distortion_sum_ = 0.0, distortion_area_ = 0.0;
    std::vector<char> exclusive_;                      // per material: may be lightmapped in place
    std::map<std::pair<int, int>, int> material_for_;  // (material, atlas) -> material
};

Result<AtlasReport> build_uv_atlas_in(Scene& scene, const AtlasOptions& options) {
    if (Status s = check_atlas_options(options); !s.ok()) return s.error();
    return AtlasBuilder(scene, options).run();
}

}  // namespace

}  // namespace hmdnode
