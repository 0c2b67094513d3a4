// Edge-collapse engine: collapses in order of a pluggable cost (CollapseCost: qem, curvature-qem,
// formula1, melax), on flat arrays. This file picks the schedule and holds what every collapse
// does once the check allowed it: the record for the progressive mesh, the kept position's move
// and its attributes, the snapshots of the levels.
//
// Papers: M. Garland, P. Heckbert, "Surface simplification using quadric error metrics",
// SIGGRAPH 1997 (the greedy loop over edge candidates, boundary planes); H. Hoppe, "Progressive
// meshes", SIGGRAPH 1996 (the collapse record). The data layout follows meshoptimizer's
// simplifier (A. Kapoulkine).
//
// The files, in the order a collapse meets them:
// - collapse_mesh.{hpp,cpp}: the weld into wedges and positions, the adjacency, the kinds of the
//   positions (free, border, seam, locked) and the moves they allow on an edge;
// - greedy_schedule.cpp: costs that read the faces around an endpoint (formula1, melax): strict
//   greedy order on a lazy binary heap, corner lists spliced in O(1) per collapse;
// - pass_schedule.{hpp,cpp}: costs of the endpoints only (qem, curvature-qem): passes in the
//   manner of meshoptimizer over flat adjacency lists rebuilt per pass, work split in two regions
//   (and on a helper thread where the caller allows one); candidate_sort.cpp: its radix sort;
// - collapse_check.hpp: the one check that refuses a collapse, for both schedules;
// - this file: applying an allowed collapse (attributes, record) and the levels.
// A level is snapshotted when the live face count first drops to or below its target, so all
// levels come from one run.
//
// Rules, for every cost:
// - seams: a seam position only collapses along a seam edge, each wedge onto the wedge of the
//   kept position on its side, so both sides move together and UV charts (TEXCOORD_0 and the
//   lightmap's TEXCOORD_1) stay consistent on every level; seam ends and corners are locked;
// - attributes (normals, uv0, uv1, colours): a merge of two free positions takes them where the
//   new point lies, barycentric in the face around either endpoint that it projects into
//   (merge_attributes.hpp); otherwise, and where no face contains the projection, they are
//   interpolated per wedge at the parameter of the new point projected on the edge (lerp_wedge(),
//   move_kept()); normals renormalised;
// - material boundaries: one primitive has one material, so there is no boundary inside it;
// - borders: border positions only collapse along border edges, onto the neighbouring border
//   position; lock_borders forbids removing them at all (they can still be collapse targets,
//   where they stay bit-exact). Only two free positions merge at a new point.
//
// Departure: the edge-collapse algorithms were first planned on OpenMesh's Decimater. Its generic
// module and property machinery make ModQuadric slow; this engine does the same work with QEM on
// flat arrays, so OpenMesh stays the baseline only (simplify_openmesh_quadric). The measurements:
// docs/simplification.md ("Measurements behind the engine's choices") and docs/lod-generation.md
// (Benchmark).
//
// Cost: O(V + F) to build; pass schedule O(E) per pass; greedy schedule O(E log E). Memory
// O(V + F + E) (collapse_mesh.hpp, and each schedule's candidates). No allocation per collapse
// except the progressive-mesh record; the arrays come from the scratch cache (scratch.hpp).
#include "collapse_engine.hpp"

#include <algorithm>
#include <cmath>

#include "collapse_mesh.hpp"

namespace hmdnode::lod_detail {

// Attribute placement: what the kept wedges carry after a collapse moved their position. A merge
// of two free positions takes them where the new point lies (merge_attributes.hpp, computed by
// the schedule, which walks the faces); everything else, and a merge whose point projects into no
// face, interpolates each wedge of the kept position towards the removed position's wedge on the
// same side at the parameter of the new point projected on the edge (lerp_wedge()). Both are
// applied at once by move_kept().
PmWedge lerp_wedge(const PmWedge& from, const PmWedge& to, float t, bool has_normals) {
    PmWedge w = to;
    w.normal = from.normal + (to.normal - from.normal) * t;
    if (has_normals) {
        const float len = glm::length(w.normal);
        w.normal = len > 0.0f ? w.normal / len : to.normal;
    }
    w.uv0 = from.uv0 + (to.uv0 - from.uv0) * t;
    w.uv1 = from.uv1 + (to.uv1 - from.uv1) * t;
    w.color = from.color + (to.color - from.color) * t;
    return w;
}

// The progressive-mesh record of a collapse (H. Hoppe 1996): what a vertex split restores.
VertexSplit* EngineCore::start_record(Worker& w, uint32_t u, uint32_t v) {
    if (!log_) return nullptr;
    VertexSplit& rec = (&w == &workers_[0] ? records_ : w.records).emplace_back();
    rec.removed = {u, m_.positions[u]};
    rec.kept = v;
    rec.kept_position = m_.positions[v];
    for (uint32_t i = wedge_first_[u]; i < wedge_first_[u + 1]; ++i) {
        rec.removed_wedges.push_back(wedges_[wedge_list_[i]]);
    }
    // note: in the pass schedule, corners are rewritten only at the end of the pass.
    auto wedge = [&](uint32_t c) { return flat_ ? wedge_remap_[m_.corners[c]] : m_.corners[c]; };
    for (uint32_t f : w.shared_faces) {
        rec.faces.push_back({f, {wedge(3 * f), wedge(3 * f + 1), wedge(3 * f + 2)}});
    }
    return &rec;
}

void EngineCore::move_kept(Worker& w, uint32_t u, uint32_t v, const glm::dvec3& target,
                           const WedgeMap& map, VertexSplit* rec, const PendingBlend* merged) {
    const glm::dvec3 pu = m_.positions[u], pv = m_.positions[v];
    const glm::dvec3 e = pv - pu;
    const double ee = glm::dot(e, e);
    const float t = ee > 0.0 ? float(std::clamp(glm::dot(target - pu, e) / ee, 0.0, 1.0)) : 1.0f;
    // note: without attributes a wedge is only its position: nothing to interpolate (and without
    // a log either, wedges_ is empty).
    const bool attributes = has_normals_ || has_uv0_ || has_uv1_ || has_colors_;
    for (int i = 0; i < map.count && !wedges_.empty(); ++i) {
        if (rec) rec->kept_wedges.push_back(wedges_[map.to[i]]);
        if (!attributes) continue;
        PendingBlend b;
        if (merged) {
            b = *merged;
            b.to = map.to[i];
        } else {
            b = {map.to[i], map.to[i], {map.from[i], map.to[i], map.to[i]}, {0.0f, t, 0.0f}, true};
        }
        // note: in the pass schedule a placement reads only wedges of positions whose faces lie in
        // its region, and the placements of a pass are applied in order, so waiting changes
        // nothing but where the reads happen.
        if (flat_ && !rec) {
            w.blends.push_back(b);
        } else {
            apply_blend(b);
        }
    }
    m_.positions[v] = glm::vec3(target);
}

void EngineCore::apply_blend(const PendingBlend& b) {
    if (b.lerp) {
        wedges_[b.to] = lerp_wedge(wedges_[b.src[0]], wedges_[b.src[1]], b.l[1], has_normals_);
        return;
    }
    const PmWedge &w0 = wedges_[b.src[0]], &w1 = wedges_[b.src[1]], &w2 = wedges_[b.src[2]];
    PmWedge& out = wedges_[b.to];
    const float l0 = b.l[0], l1 = b.l[1], l2 = b.l[2];
    const glm::vec3 normal = w0.normal * l0 + w1.normal * l1 + w2.normal * l2;
    const glm::vec3 fallback = wedges_[b.fallback].normal;
    out.uv0 = w0.uv0 * l0 + w1.uv0 * l1 + w2.uv0 * l2;
    out.uv1 = w0.uv1 * l0 + w1.uv1 * l1 + w2.uv1 * l2;
    out.color = w0.color * l0 + w1.color * l1 + w2.color * l2;
    out.normal = normal;
    if (has_normals_) {
        const float len = glm::length(normal);
        out.normal = len > 0.0f ? normal / len : fallback;
    }
}

void EngineCore::flush_attributes(Worker& w) {
    const size_t n = w.blends.size();
    if (n == 0) return;
    const Phase phase(*this, &SimplifyProfile::attributes_ms);
    for (size_t i = 0; i < n; ++i) {
        if (prefetch_ && i + 8 < n) {
            const PendingBlend& ahead = w.blends[i + 8];
            for (uint32_t s : ahead.src) __builtin_prefetch(&wedges_[s]);
            __builtin_prefetch(&wedges_[ahead.to]);
        }
        apply_blend(w.blends[i]);
    }
    w.blends.clear();
}

void EngineCore::finish_collapse(Worker& w, const CollapseCandidate& c) {
    const double error = cost_.error_of(m_, c);
    if (error < 0.0) w.error_unknown = true;
    w.max_error = std::max(w.max_error, error);
    cost_.collapsed(m_, c);
}

void EngineCore::begin(std::span<const size_t> targets, std::vector<SimplifiedLevel>& levels,
                       size_t& ti) {
    classify();
    if (two_way_.has_helper()) {
        m_.region_start = region_start_;
        m_.split = &two_way_;
    }
    cost_.init(m_);
    levels.reserve(targets.size());
    ti = 0;
    while (ti < targets.size() && live_faces_ <= targets[ti]) {
        levels.push_back(snapshot());
        ++ti;
    }
    initial_faces_ = live_faces_;
}

void EngineCore::after_collapse(std::span<const size_t> targets,
                                std::vector<SimplifiedLevel>& levels, size_t& ti) {
    ++collapses_;
    while (ti < targets.size() && live_faces_ <= targets[ti]) {
        levels.push_back(snapshot());
        ++ti;
    }
    const size_t last_target = targets.back();
    if (options_.progress && (collapses_ & 4095) == 0 && initial_faces_ > last_target) {
        options_.progress(double(initial_faces_ - live_faces_) /
                          double(initial_faces_ - last_target));
    }
}

Result<std::vector<SimplifiedLevel>> EngineCore::end(std::span<const size_t> targets,
                                                     std::vector<SimplifiedLevel>& levels,
                                                     size_t& ti) {
    while (ti < targets.size()) {  // not reachable: the closest we got
        levels.push_back(snapshot());
        ++ti;
    }
    if (options_.progress) options_.progress(1.0);
    if (options_.stats) *options_.stats = SimplifyStats{passes_, collapses_};
    if (options_.profile)
        options_.profile->collapses = collapses_, options_.profile->passes = passes_;

    if (log_) {
        ProgressiveMesh& pm = *log_;
        pm = ProgressiveMesh{};
        pm.has_normals = has_normals_, pm.has_uv0 = has_uv0_, pm.has_uv1 = has_uv1_;
        pm.has_colors = has_colors_;
        pm.material = material_;
        pm.position_count = uint32_t(m_.positions.size());
        pm.wedge_count = uint32_t(wedges_.size());
        pm.face_count = uint32_t(m_.face_alive.size());
        for (uint32_t p = 0; p < pm.position_count; ++p) {
            if (!m_.position_alive[p]) continue;
            pm.base_positions.push_back({p, m_.positions[p]});
            for (uint32_t i = wedge_first_[p]; i < wedge_first_[p + 1]; ++i) {
                pm.base_wedges.push_back(wedges_[wedge_list_[i]]);
            }
        }
        std::sort(pm.base_wedges.begin(), pm.base_wedges.end(),
                  [](const PmWedge& a, const PmWedge& b) { return a.id < b.id; });
        for (uint32_t f = 0; f < pm.face_count; ++f) {
            if (m_.face_alive[f]) {
                pm.base_faces.push_back(
                    {f, {m_.corners[3 * f], m_.corners[3 * f + 1], m_.corners[3 * f + 2]}});
            }
        }
        pm.splits.assign(std::make_move_iterator(records_.rbegin()),
                         std::make_move_iterator(records_.rend()));
    }
    return std::move(levels);
}

SimplifiedLevel EngineCore::snapshot() {
    const Phase phase(*this, &SimplifyProfile::snapshots_ms);
    flush();
#ifndef NDEBUG
    check_invariants();
#endif
    SimplifiedLevel level;
    level.primitive =
        compact_primitive(m_.positions, m_.wedge_position, wedges_, m_.corners, m_.face_alive,
                          has_normals_, has_uv0_, has_uv1_, has_colors_, material_);
    const bool unknown = workers_[0].error_unknown || workers_[1].error_unknown;
    level.estimated_error = unknown ? -1.0 : std::max(workers_[0].max_error, workers_[1].max_error);
    return level;
}

#ifndef NDEBUG
void EngineCore::check_invariants() const {
    size_t live = 0;
    for (uint32_t f = 0; f < uint32_t(m_.face_alive.size()); ++f) {
        if (!m_.face_alive[f]) continue;
        ++live;
        const uint32_t p0 = m_.face_position(f, 0), p1 = m_.face_position(f, 1),
                       p2 = m_.face_position(f, 2);
        assert(p0 != p1 && p1 != p2 && p0 != p2);  // no live face on a repeated position
        for (int k = 0; k < 3; ++k) {
            const uint32_t p = m_.face_position(f, k);
            assert(m_.position_alive[p]);  // no live face on a removed position
            assert(m_.wedge_position[m_.corners[3 * f + k]] == p);
            assert(std::isfinite(m_.positions[p].x) && std::isfinite(m_.positions[p].y) &&
                   std::isfinite(m_.positions[p].z));
            (void)p;
        }
    }
    assert(live == live_faces_);  // the face count the targets are met by
    (void)live;
}
#endif

Result<std::vector<SimplifiedLevel>> run_edge_collapse(const Primitive& in,
                                                       std::span<const size_t> targets,
                                                       const SimplifyOptions& options,
                                                       CollapseCost& cost, ProgressiveMesh* log) {
    // note: a cost that reads the faces around an endpoint changes with every collapse in its
    // ring, so it needs the strict greedy order; a cost of the endpoints only stays exact within
    // a pass.
    if (cost.depends_on_ring()) return run_greedy_schedule(in, targets, options, cost, log);
    return run_pass_schedule(in, targets, options, cost, log);
}

}  // namespace hmdnode::lod_detail
