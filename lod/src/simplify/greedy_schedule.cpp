// The greedy schedule, for costs that read the faces around an endpoint (formula1, melax): strict
// greedy order, as the papers do (these costs are cheap to mis-order otherwise: a collapse in the
// ring changes them).
//
// Paper: M. Garland, P. Heckbert, "Surface simplification using quadric error metrics", SIGGRAPH
// 1997 (the greedy loop over a heap of edge candidates).
// Method: a binary min-heap of edge candidates with lazy deletion: each entry carries the version
// of both endpoints, a collapse bumps the kept position and its 1-ring and re-evaluates every
// edge of the ring; an entry whose cost rose since it was queued goes back at the new cost. The
// adjacency is one singly linked list of corners per position: a collapse splices the removed
// position's list onto the kept one (O(1), no allocation), dead faces are pruned lazily. When the
// heap runs dry before the last target, every live edge is evaluated again, until a round
// collapses nothing. The check is collapse_check.hpp's.
//
// Cost: O(E log E) time (each collapse re-evaluates O(valence^2) edges); 20 bytes per heap entry.
#include <algorithm>
#include <cassert>
#include <cmath>

#include "collapse_check.hpp"
#include "collapse_mesh.hpp"
#include "merge_attributes.hpp"

namespace hmdnode::lod_detail {
namespace {

struct HeapEntry {
    float cost;
    uint32_t a, b;
    uint32_t version_a, version_b;
};
struct HeapGreater {
    bool operator()(const HeapEntry& x, const HeapEntry& y) const { return x.cost > y.cost; }
};

class GreedySchedule final : public EngineCore {
  public:
    GreedySchedule(const SimplifyOptions& options, CollapseCost& cost, ProgressiveMesh* log)
        : EngineCore(options, cost, log, /*flat_lists=*/false, /*helper=*/false) {}

    Result<std::vector<SimplifiedLevel>> run(const Primitive& in, std::span<const size_t> targets);

  private:
    void push_edge(uint32_t a, uint32_t b);
    void push_all_edges();
    bool try_collapse(const CollapseCandidate& c);
    void reevaluate_around(uint32_t v);
#ifndef NDEBUG
    void check_adjacency(uint32_t v) const;
#endif

    Scratch<HeapEntry> heap_;
    Scratch<uint32_t> version_;  // per position, bumped when a collapse changes its candidates
    Scratch<uint32_t> ring_;     // reevaluate_around()'s, reused by every collapse
};

Result<std::vector<SimplifiedLevel>> GreedySchedule::run(const Primitive& in,
                                                         std::span<const size_t> targets) {
    prefetch_ = false;
    build(in);
    version_.assign(m_.positions.size(), 0);
    std::vector<SimplifiedLevel> levels;
    size_t ti = 0;
    begin(targets, levels, ti);
    m_.face_unit_normals.resize(m_.face_alive.size());
    for (uint32_t f = 0; f < uint32_t(m_.face_alive.size()); ++f) {
        m_.face_unit_normals[f] = m_.face_unit_normal(f);
    }
    heap_.reserve(m_.corners.size() * 2);
    push_all_edges();
    size_t collapses_since_rebuild = 0;
    while (ti < targets.size()) {
        if (heap_.empty()) {
            if (collapses_since_rebuild == 0) break;
            collapses_since_rebuild = 0;
            push_all_edges();
            continue;
        }
        std::pop_heap(heap_.begin(), heap_.end(), HeapGreater{});
        const HeapEntry e = heap_.back();
        heap_.pop_back();
        assert(e.a != e.b && e.a < m_.positions.size() && e.b < m_.positions.size());
        assert(std::isfinite(e.cost) && e.cost >= 0.0f);  // a cost the heap can order
        if (!m_.position_alive[e.a] || !m_.position_alive[e.b] || version_[e.a] != e.version_a ||
            version_[e.b] != e.version_b) {
            continue;
        }
        const EdgeMoves moves = edge_moves(e.a, e.b);
        if (!moves.a_to_b && !moves.b_to_a) continue;
        CollapseCandidate c;
        if (!cost_.evaluate(m_, e.a, e.b, moves, c)) continue;
        if (float(c.cost) > e.cost) {  // the neighbourhood changed: queue at the new cost
            heap_.push_back({float(c.cost), e.a, e.b, e.version_a, e.version_b});
            std::push_heap(heap_.begin(), heap_.end(), HeapGreater{});
            continue;
        }
        if (!try_collapse(c)) {
            continue;
        }
        ++collapses_since_rebuild;
        reevaluate_around(c.to);
        after_collapse(targets, levels, ti);
    }
    return end(targets, levels, ti);
}

void GreedySchedule::push_edge(uint32_t a, uint32_t b) {
    const EdgeMoves moves = edge_moves(a, b);
    if (!moves.a_to_b && !moves.b_to_a) return;
    CollapseCandidate c;
    if (!cost_.evaluate(m_, a, b, moves, c)) return;
    heap_.push_back({float(c.cost), a, b, version_[a], version_[b]});
    std::push_heap(heap_.begin(), heap_.end(), HeapGreater{});
}

void GreedySchedule::push_all_edges() {
    const uint32_t np = uint32_t(m_.positions.size());
    for (uint32_t p = 0; p < np; ++p) {
        if (!m_.position_alive[p]) continue;
        Scratch<uint32_t>& mark = workers_[0].mark;
        const uint32_t s = ++workers_[0].stamp;
        m_.for_each_face(p, [&](uint32_t f, int k) {
            for (int j = 1; j < 3; ++j) {
                const uint32_t q = m_.face_position(f, (k + j) % 3);
                if (q > p && mark[q] != s) {
                    mark[q] = s;
                    push_edge(p, q);
                }
            }
        });
    }
}

[[gnu::flatten]] bool GreedySchedule::try_collapse(const CollapseCandidate& c) {
    Worker& w = workers_[0];
    WedgeMap map;
    // note: the corner lists hold the current positions; dead faces are pruned on the way.
    auto around = [this](uint32_t p, auto&& f) {
        bool more = true;
        walk_pruning(p, [&](uint32_t face, int k) {
            if (!more) return;
            more = f(face, uint32_t(k), m_.face_position(face, k == 2 ? 0 : k + 1),
                     m_.face_position(face, k == 0 ? 2 : k - 1));
        });
    };
    if (check_collapse(w, c, map, around) == 0) return false;
    const uint32_t u = c.from, v = c.to;
    const glm::dvec3 target = c.moves ? c.position : glm::dvec3(m_.positions[v]);
    const Scratch<uint32_t>& shared_faces = w.shared_faces;

    // Apply: u's corners go to v (their wedges through the map), the faces on the edge die, and
    // u's list is spliced onto v's.
    VertexSplit* rec = start_record(w, u, v);
    if (c.moves) {
        PendingBlend merged;
        const bool in_face =
            map.count == 1 && merges_free(u, v) &&
            merged_attributes(
                u, v, target, around, [this](uint32_t cr) { return m_.corners[cr]; }, merged);
        move_kept(w, u, v, target, map, rec, in_face ? &merged : nullptr);
    }
    auto apply_corner = [&](uint32_t cr) {
        const uint32_t f = cr / 3;
        if (!m_.face_alive[f]) return;
        if (std::find(shared_faces.begin(), shared_faces.end(), f) != shared_faces.end()) {
            m_.face_alive[f] = 0;
            --live_faces_;
            return;
        }
        const uint32_t wedge = m_.corners[cr];
        for (int i = 0; i < map.count; ++i) {
            if (map.from[i] == wedge) {
                if (rec) rec->corners.push_back({cr, wedge});
                m_.corners[cr] = map.to[i];
                m_.corner_position[cr] = v;
                break;
            }
        }
    };
    uint32_t last = kNone;
    for (uint32_t cr = m_.corner_head[u]; cr != kNone; cr = m_.corner_next[cr]) {
        last = cr;
        apply_corner(cr);
    }
    if (last != kNone) {
        m_.corner_next[last] = m_.corner_head[v];
        m_.corner_head[v] = m_.corner_head[u];
    }
    m_.corner_head[u] = kNone;
    m_.position_alive[u] = 0;
    if (!m_.face_unit_normals.empty()) {
        m_.for_each_face(
            v, [&](uint32_t f, int) { m_.face_unit_normals[f] = m_.face_unit_normal(f); });
    }
    finish_collapse(w, c);
    ++version_[v];
#ifndef NDEBUG
    check_adjacency(v);
#endif
    return true;
}

void GreedySchedule::reevaluate_around(uint32_t v) {
    // Ring of v, pruning dead corners from its list on the way.
    ring_.clear();
    Scratch<uint32_t>& mark = workers_[0].mark;
    const uint32_t s = ++workers_[0].stamp;
    mark[v] = s;
    uint32_t prev = kNone;
    for (uint32_t c = m_.corner_head[v]; c != kNone;) {
        const uint32_t next = m_.corner_next[c];
        const uint32_t f = c / 3;
        if (!m_.face_alive[f]) {
            if (prev == kNone) {
                m_.corner_head[v] = next;
            } else {
                m_.corner_next[prev] = next;
            }
            c = next;
            continue;
        }
        const int k = int(c % 3);
        for (int j = 1; j < 3; ++j) {
            const uint32_t x = m_.face_position(f, (k + j) % 3);
            if (mark[x] != s) {
                mark[x] = s;
                ring_.push_back(x);
            }
        }
        prev = c;
        c = next;
    }
    if (cost_.depends_on_ring()) {
        for (uint32_t x : ring_) ++version_[x];
    }
    for (uint32_t x : ring_) push_edge(v, x);
    if (!cost_.depends_on_ring()) return;
    // Every other edge of the ring positions (each once: an edge between two ring positions is
    // pushed from its lower id).
    const size_t ring_size = ring_.size();
    for (size_t i = 0; i < ring_size; ++i) {
        const uint32_t x = ring_[i];
        m_.for_each_face(x, [&](uint32_t f, int k) {
            for (int j = 1; j < 3; ++j) {
                const uint32_t y = m_.face_position(f, (k + j) % 3);
                if (y == v) continue;
                if (mark[y] == s && y < x) continue;
                bool seen = false;
                for (size_t r = ring_size; r < ring_.size(); ++r) seen |= ring_[r] == y;
                if (seen) continue;
                ring_.push_back(y);
            }
        });
        for (size_t r = ring_size; r < ring_.size(); ++r) push_edge(x, ring_[r]);
        ring_.resize(ring_size);
    }
}

#ifndef NDEBUG
// After a collapse onto v: every live corner in v's list is v's, and v's faces are live.
void GreedySchedule::check_adjacency(uint32_t v) const {
    assert(m_.position_alive[v]);
    for (uint32_t c = m_.corner_head[v]; c != kNone; c = m_.corner_next[c]) {
        if (m_.face_alive[c / 3]) assert(m_.corner_position[c] == v);
    }
}
#endif

}  // namespace

Result<std::vector<SimplifiedLevel>> run_greedy_schedule(const Primitive& in,
                                                         std::span<const size_t> targets,
                                                         const SimplifyOptions& options,
                                                         CollapseCost& cost, ProgressiveMesh* log) {
    GreedySchedule schedule(options, cost, log);
    return schedule.run(in, targets);
}

}  // namespace hmdnode::lod_detail
