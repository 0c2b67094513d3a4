// Where a collapse is refused: the one validity check of an edge collapse u -> v, used by both
// schedules (greedy_schedule.cpp, pass_schedule.cpp). A collapse the kinds allow (moves_for() in
// collapse_mesh.cpp: seams, borders, locked positions) is refused here when
// - an endpoint is gone, or u == v;
// - the edge has no face or more than two (not a manifold edge);
// - u's wedges do not map onto v's consistently (a seam position: each wedge onto the wedge of
//   the kept position on its side; more than four wedges);
// - the link condition fails (the endpoints share other neighbours than the one or two positions
//   of the faces on the edge), an interior edge joins two border positions, or fewer than three
//   neighbours would be left (topology_ok()): manifold input stays manifold, closed stays closed;
// - a face around a moved endpoint would turn by more than 90 degrees from its current normal or
//   from its input normal (so it cannot turn over in several small steps), or become degenerate
//   (fan_face());
// - two faces around the kept position would fold onto each other (folds()): two faces of the fan
//   that share an edge at the kept position, or a face of the fan that turned by more than
//   kFoldMinTurn and the face across its outer edge, end with unit normals whose dot product is
//   below kFoldCosine (folded by more than 143 degrees), where they were not so before (two faces
//   that become neighbours only through the collapse were not) and, for costs of the endpoints
//   only (qem, curvature-qem), where their input faces were not folded as much either (the two
//   sides of a thin feature meet at coarse levels). The flip guard above checks each face alone,
//   so two neighbours turning less than 90 degrees each, in opposite directions, pass it.
// A new guard goes into check_collapse() (or the functions it calls), and so into both schedules.
//
// Papers: T. Dey, H. Edelsbrunner, S. Guha, D. Nekhayev, "Topology preserving edge contraction",
// Publications de l'Institut Mathematique (Beograd) 66(80), 1999 (the link condition);
// M. Garland, P. Heckbert, "Surface simplification using quadric error metrics", SIGGRAPH 1997
// (the flip guard).
// Cost: one walk of the faces around each endpoint, O(valence); the fold check O(valence^2)
// comparisons of indices plus one walk around an outer corner per face that turned by more than
// kFoldMinTurn (few: most collapses turn every face by less). No allocation.
#pragma once

#include <cassert>
#include <cmath>

#include "collapse_mesh.hpp"

namespace hmdnode::lod_detail {

// Two faces around the kept position must not end folded onto each other: the dot product of
// their unit normals stays at or above this (a fold of at most 143 degrees) unless it was below
// before. note: -0.5 (120 degrees) also refused the thin spikes of coarse levels: qem stopped at
// 66 faces for the spot's 58, with a third more mean error.
inline constexpr double kFoldCosine = -0.8;
// A face of the fan whose normal moved by less than this (|n1 - n0|, about 5.7 degrees) is not
// checked against the face across its outer edge: it cannot fold onto it unless the two were
// already within that turn of folded (dot below kFoldCosine + 0.1).
inline constexpr double kFoldMinTurn = 0.1;

inline int EngineCore::WedgeMap::slot(uint32_t w) {
    for (int i = 0; i < count; ++i) {
        if (from[i] == w) return i;
    }
    if (count == 4) {
        bad = true;
        return -1;
    }
    from[count] = w;
    to[count] = kNone;
    return count++;
}

inline void EngineCore::WedgeMap::map(int s, uint32_t w) {
    if (to[s] != kNone && to[s] != w) bad = true;
    to[s] = w;
}

inline bool EngineCore::WedgeMap::complete() const {
    for (int i = 0; i < count; ++i) {
        if (to[i] == kNone) return false;
    }
    return true;
}

// Adds the face f (corner `from` moving to `target`, other corners p1, p2) to w.fan with its
// normals before and after (unnormalised), and says whether the move turns it past 90 degrees
// from its current or its input normal, or makes it degenerate.
inline bool EngineCore::fan_face(Worker& w, bool of_kept, const glm::dvec3& from,
                                 const glm::dvec3& target, uint32_t p1, uint32_t p2,
                                 uint32_t f) const {
    const glm::dvec3 b = m_.positions[p1], d = m_.positions[p2];
    const glm::dvec3 n0 = glm::cross(b - from, d - from);
    const glm::dvec3 n1 = glm::cross(b - target, d - target);
    // note: the fold check finds the face sharing the edge (kept, next) by its prev.
    w.slot[p2] = uint32_t(w.fan.size());
    w.fan.push_back({p1, p2, of_kept, n0, n1, f});
    const double l0 = glm::dot(n0, n0);
    if (l0 == 0.0) return false;  // degenerate already: nothing to keep
    // note: exactly 90 degrees passes (the cube diagonal of Lazányi 2003, Figure 5); the input
    // face's normal guards against a face turning over in several small steps.
    const double l1 = glm::dot(n1, n1);
    return l1 <= 1e-12 * l0 || glm::dot(n0, n1) < 0.0 ||
           glm::dot(glm::dvec3(input_normals_[f]), n1) < 0.0;
}

// Whether unnormalised normals a and b are folded more than kFoldCosine: dot(a, b) < k |a| |b|.
inline bool folded(const glm::dvec3& a, const glm::dvec3& b) {
    const double d = glm::dot(a, b);
    if (d >= 0.0) return false;
    return d * d > kFoldCosine * kFoldCosine * glm::dot(a, a) * glm::dot(b, b);
}

template <class Around>
bool EngineCore::folds(const Worker& w, uint32_t u, uint32_t v, Around&& around) const {
    // note: a fold the input surface had (the two faces' input normals folded as much: the two
    // sides of a thin ear, horn or leg) is the coarse shape, not a fold-over (EngineCore::
    // input_folds_; docs/simplification.md, "The fold guard and thin features").
    auto input_folded = [this](uint32_t f, uint32_t g) {
        return input_folds_ && folded(glm::dvec3(input_normals_[f]), glm::dvec3(input_normals_[g]));
    };
    const size_t n = w.fan.size();
    for (size_t i = 0; i < n; ++i) {
        const FanFace& x = w.fan[i];
        // The face sharing the edge (kept, x.next): the one whose prev is x.next (fan_face()
        // noted it in w.slot). A pair of one face of each endpoint was not adjacent before (the
        // removed faces lay between them), so any fold of it is new.
        const uint32_t j = w.slot[x.next];
        if (j < n && j != i && w.fan[j].prev == x.next) {
            const FanFace& y = w.fan[j];
            if (folded(x.after, y.after) &&
                (x.of_kept != y.of_kept || !folded(x.before, y.before)) &&
                !input_folded(x.face, y.face))
                return true;
        }
        // The face across the outer edge (x.next, x.prev), only where x turned by more than
        // kFoldMinTurn: |x.after/|x.after| - x.before/|x.before||^2 = 2 - 2 cos.
        const double ab = glm::dot(x.after, x.before);
        const double aa = glm::dot(x.after, x.after), bb = glm::dot(x.before, x.before);
        constexpr double kCos = 1.0 - 0.5 * kFoldMinTurn * kFoldMinTurn;
        if (ab >= 0.0 && ab * ab >= kCos * kCos * aa * bb) continue;
        // note: seen from x.prev as (x.prev, x.next, o).
        uint32_t o = kNone, of = kNone;
        around(x.prev, [&](uint32_t face, uint32_t, uint32_t a, uint32_t b) {
            if (a != x.next) return true;
            o = b, of = face;
            return false;
        });
        if (o == kNone || o == u || o == v) continue;
        const glm::dvec3 pa = m_.positions[x.prev];
        const glm::dvec3 on =
            glm::cross(glm::dvec3(m_.positions[x.next]) - pa, glm::dvec3(m_.positions[o]) - pa);
        if (folded(x.after, on) && !folded(x.before, on) && !input_folded(x.face, of)) return true;
    }
    return false;
}

// The link condition, no interior edge between two border positions, enough neighbours left.
inline bool EngineCore::topology_ok(uint32_t u, uint32_t v, size_t shared,
                                    const LinkCount& n) const {
    const bool border_edge = shared == 1;
    if (size_t(n.common) != shared) return false;  // link condition
    if (!border_edge && m_.on_border[u] && m_.on_border[v]) return false;
    return border_edge ? n.deg_u + n.deg_v - 3 >= 2 : n.deg_u + n.deg_v - 4 >= 3;
}

// The check of collapse c (u = c.from removed onto v = c.to, v moved to c.position when c.moves).
// `around(p, f)` calls f(face, k, a, b) for every live face around p, k p's corner in it, a and b
// the current positions of its next and previous corners (a != b), until f returns false.
// Returns the number of faces on the edge (1 or 2, the faces in w.shared_faces, u's wedges mapped
// in `map`), or 0 when the collapse is refused.
template <class Around>
size_t EngineCore::check_collapse(Worker& w, const CollapseCandidate& c, WedgeMap& map,
                                  Around&& around) const {
    const uint32_t u = c.from, v = c.to;
    if (!m_.position_alive[u] || !m_.position_alive[v] || u == v) return 0;
    Scratch<uint32_t>& shared_faces = w.shared_faces;
    LinkCount link = link_count(w);
    shared_faces.clear();
    w.fan.clear();
    bool flips = false;
    const glm::dvec3 target = c.moves ? c.position : glm::dvec3(m_.positions[v]);
    const glm::dvec3 pu = m_.positions[u];
    // note: a position with a single wedge (no seam through it, the common case) needs no corner
    // read, nor does a free position after its first corner (what collapses onto it maps onto
    // its one wedge).
    const bool u_free = m_.kinds[u] == VertexKind::Free;
    const uint32_t sole_u = sole_wedge_[u], sole_v = sole_wedge_[v];
    uint32_t wu = sole_u;
    around(u, [&](uint32_t f, uint32_t k, uint32_t a, uint32_t b) {
        assert(a != b && m_.face_alive[f]);
        if (sole_u == kNone && (!u_free || wu == kNone)) wu = m_.corners[3 * f + k];
        const int slot = map.slot(wu);
        if (slot < 0) return false;
        if (a == v || b == v) {
            shared_faces.push_back(f);
            const uint32_t kv = a == v ? (k == 2 ? 0 : k + 1) : (k == 0 ? 2 : k - 1);
            map.map(slot, sole_v != kNone ? sole_v : m_.corners[3 * f + kv]);
        } else if (!flips) {
            flips = fan_face(w, false, pu, target, a, b, f);
        }
        link.of_u(a);
        link.of_u(b);
        return true;
    });
    if (map.bad || flips) return 0;
    const size_t shared = shared_faces.size();
    if (shared == 0 || shared > 2 || !map.complete()) return 0;
    const glm::dvec3 pv = m_.positions[v];
    around(v, [&](uint32_t f, uint32_t, uint32_t a, uint32_t b) {
        link.of_v(a);
        link.of_v(b);
        if (!flips && a != u && b != u) flips = fan_face(w, true, pv, target, a, b, f) && c.moves;
        return true;
    });
    if (!topology_ok(u, v, shared, link) || flips || folds(w, u, v, around)) return 0;
    return shared;
}

}  // namespace hmdnode::lod_detail
