// The state both collapse schedules work on (greedy_schedule.cpp, pass_schedule.cpp): the welded
// mesh, its adjacency, the kinds of its positions, and what every collapse does to it whichever
// schedule picks it (the check, collapse_check.hpp; the attributes, the record, the snapshots,
// collapse_engine.cpp).
//
// Idea: the data layout of meshoptimizer's simplifier (A. Kapoulkine): vertices welded by
// position, attribute seams kept as separate "wedges" on one position, each position classified
// as free, border, seam or locked (collapse_mesh.cpp). The adjacency comes in one of two forms,
// fixed per engine: per-position singly linked corner lists (the greedy schedule: a collapse
// splices them in O(1)) or flat per-position lists (CSR) of (next, prev, corner) entries rebuilt
// once per pass (the pass schedule, pass_schedule.cpp).
//
// Cost: O(V + F) memory: about 72 bytes per face with corner lists, about 76 with flat lists, plus
// 52 bytes per wedge when the mesh has attributes or a progressive-mesh log is kept.
#pragma once

#include <array>
#include <cassert>
#include <chrono>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "collapse_engine.hpp"
#include "scratch.hpp"
#include "two_way.hpp"

namespace hmdnode::lod_detail {

// From this many input faces on, the pass schedule cuts the mesh in two regions and, when the
// caller allows a second thread (SimplifyOptions::threads >= 2), runs the halves of its work on a
// helper thread; it splits a pass in two while at least kSplitGoal collapses are left to the next
// target. The threshold lies between the test meshes: the fandisk (12 946 faces) gains, the spot
// (5 856) gained little and its coarsest level lost accuracy (docs/simplification.md,
// "Measurements behind the engine's choices").
inline constexpr size_t kSplitFaces = 8192;
inline constexpr size_t kSplitGoal = 2048;

// The part of the engine both schedules share; each schedule derives from it and adds its own
// order of collapses (GreedySchedule, PassSchedule).
class EngineCore {
  public:
    // `flat_lists`: the pass schedule's adjacency (see above); `helper`: run two-way splits on a
    // helper thread.
    EngineCore(const SimplifyOptions& options, CollapseCost& cost, ProgressiveMesh* log,
               bool flat_lists, bool helper)
        : options_(options),
          cost_(cost),
          log_(log),
          flat_(flat_lists),
          two_way_(helper),
          profile_(helper ? nullptr : options.profile),
          input_folds_(!cost.depends_on_ring()) {}
    virtual ~EngineCore() = default;
    EngineCore(const EngineCore&) = delete;
    EngineCore& operator=(const EngineCore&) = delete;

  protected:
    // A phase of the profile (SimplifyProfile): from construction to destruction, charged to
    // `field` less the phases timed inside it; reads the clock only when the call has a profile
    // (profile_: none with a helper thread, whose phases would overlap).
    class Phase {
      public:
        Phase(EngineCore& e, double SimplifyProfile::*field)
            : e_(e.profile_ ? &e : nullptr), field_(field) {
            if (e_) nested0_ = e_->profile_nested_ms_, t0_ = std::chrono::steady_clock::now();
        }
        ~Phase() {
            if (!e_) return;
            const double ms =
                std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0_)
                    .count();
            e_->profile_->*field_ += ms - (e_->profile_nested_ms_ - nested0_);
            e_->profile_nested_ms_ = nested0_ + ms;  // the enclosing phase's nested time
        }
        Phase(const Phase&) = delete;
        Phase& operator=(const Phase&) = delete;

      private:
        EngineCore* e_;
        double SimplifyProfile::*field_;
        double nested0_ = 0.0;
        std::chrono::steady_clock::time_point t0_;
    };

    // One edge of a position as gather_edges() finds it: the other endpoint q, its face count and
    // the wedges at both ends in its first two faces.
    struct EdgeGroup {
        uint32_t q, count;
        uint32_t face[2], wp[2], wq[2];
    };
    // An attribute placement waiting for flush_attributes(): wedge `to` becomes the blend of
    // wedges src with weights l (read when applied: in the pass's order, the values a placement
    // at the collapse would have read), normals renormalised (wedge `fallback`'s where the blend
    // has none).
    struct PendingBlend {
        uint32_t to, fallback;
        std::array<uint32_t, 3> src;
        std::array<float, 3> l;
        bool lerp = false;  // src[0] towards src[1] by l[1] (lerp_wedge()), the edge's rule
    };
    // A face around the kept position after a collapse, for the fold check (folds()): its other
    // two positions (next, prev in winding order), whose it was before, its normals before and
    // after (unnormalised) and its id.
    struct FanFace {
        uint32_t next, prev;
        bool of_kept;  // a face of the kept position before (else of the removed one)
        glm::dvec3 before, after;
        uint32_t face;
    };
    // What one half of a two-way split walks the mesh with (workers_[0] on the calling thread,
    // workers_[1] on the helper); the rest of the engine uses workers_[0]. note: aligned apart, so
    // that one thread's writes do not evict the lines the other reads.
    struct alignas(128) Worker {
        Scratch<uint32_t> mark, slot;  // per position: stamps and slots of the walks below
        uint32_t stamp = 0;
        // gather_edges(): the edges of a position and the wedges at it.
        Scratch<EdgeGroup> groups;
        uint32_t first_wedge_at_p = kNone, other_wedge_at_p = kNone;
        bool more_wedges_at_p = false;
        Scratch<uint32_t> shared_faces;    // of the collapse being checked (check_collapse())
        Scratch<FanFace> fan;              // of the collapse being checked (folds())
        Scratch<PendingBlend> blends;      // a pass's attribute placements (flush_attributes())
        std::vector<VertexSplit> records;  // worker 1's collapses in a split, with a log
        Scratch<ConstraintEdge> constraint_edges;  // classify(): this half's
        size_t counted = 0;                        // build(): the live faces of this half
        double max_error = 0.0;
        bool error_unknown = false;  // some applied collapse had no error estimate
    };
    // One entry of a position's flat list: the face is (p, next, prev), in winding order.
    struct AdjEntry {
        uint32_t next, prev;
        uint32_t corner;  // p's corner in it
    };
    // The wedges of a removed position and the kept position's wedge each becomes (a seam
    // position has two; more than four is refused). collapse_check.hpp.
    struct WedgeMap {
        std::array<uint32_t, 4> from{}, to{};
        int count = 0;
        bool bad = false;      // two faces disagree, or a fifth wedge
        int slot(uint32_t w);  // the slot of w, added when new; -1 when bad
        void map(int slot, uint32_t w);
        bool complete() const;  // every wedge maps somewhere
    };

    // collapse_mesh.cpp: the mesh.
    void build(const Primitive& in);
    void classify();
    void classify_position(Worker& w, uint32_t p, Scratch<ConstraintEdge>& edges);
    bool classify_simple_fan(Worker& w, uint32_t p);
    void gather_edges(Worker& w, uint32_t p);
    // The collapses the kinds allow on edge (a, b) with `shared` faces whose wedges at a and b are
    // wa and wb (the first two); edge_moves() finds them from a's corner list.
    EdgeMoves moves_for(uint32_t a, uint32_t b, int shared, const uint32_t wa[2],
                        const uint32_t wb[2]) const;
    EdgeMoves edge_moves(uint32_t a, uint32_t b) const;
    // f(face, k) for every live face around p, unlinking dead corners from p's corner list on the
    // way (flat lists: at the start of a pass every face in them is live).
    template <class F>
    void walk_pruning(uint32_t p, F&& f) {
        if (flat_) {
            for (uint32_t i = adj_first_[p], end = adj_first_[p + 1]; i < end; ++i) {
                const uint32_t c = adj_[i].corner;
                const uint32_t face = c / 3;
                f(face, int(c - 3 * face));
            }
            return;
        }
        uint32_t prev = kNone;
        for (uint32_t c = m_.corner_head[p]; c != kNone;) {
            const uint32_t next = m_.corner_next[c];
            const uint32_t face = c / 3;
            if (!m_.face_alive[face]) {
                (prev == kNone ? m_.corner_head[p] : m_.corner_next[prev]) = next;
            } else {
                f(face, int(c - 3 * face));
                prev = c;
            }
            c = next;
        }
    }

    // collapse_check.hpp: the one check of a collapse, for both schedules.
    template <class Around>
    size_t check_collapse(Worker& w, const CollapseCandidate& c, WedgeMap& map,
                          Around&& around) const;
    bool fan_face(Worker& w, bool of_kept, const glm::dvec3& from, const glm::dvec3& target,
                  uint32_t p1, uint32_t p2, uint32_t f) const;
    // Whether the collapse of u onto v (its fan in w.fan) folds two faces onto each other.
    template <class Around>
    bool folds(const Worker& w, uint32_t u, uint32_t v, Around&& around) const;
    // The attributes at `target` of the merge of free positions u and v (one wedge each, read
    // through `wedge_of(corner)`): barycentric in the face around u or v, before the collapse,
    // that target projects into. False where none contains its projection.
    // Whether a collapse of u onto v merges two free positions with attributes to place.
    bool merges_free(uint32_t u, uint32_t v) const {
        return !wedges_.empty() && (has_normals_ || has_uv0_ || has_uv1_ || has_colors_) &&
               m_.kinds[u] == VertexKind::Free && m_.kinds[v] == VertexKind::Free;
    }
    template <class Around, class WedgeOf>
    bool merged_attributes(uint32_t u, uint32_t v, const glm::dvec3& target, Around&& around,
                           WedgeOf&& wedge_of, PendingBlend& out) const;
    // The neighbours of a collapse's endpoints u and v, counted through a mark array with three
    // fresh stamps: their degrees and the neighbours they share, for topology_ok().
    struct LinkCount {
        Scratch<uint32_t>& mark;
        uint32_t s_u, s_common, s_v;
        int deg_u = 0, deg_v = 0, common = 0;
        void of_u(uint32_t x) {
            if (mark[x] != s_u) mark[x] = s_u, ++deg_u;
        }
        void of_v(uint32_t x) {  // after every neighbour of u
            if (mark[x] == s_u) {
                mark[x] = s_common, ++common, ++deg_v;
            } else if (mark[x] != s_common && mark[x] != s_v) {
                mark[x] = s_v, ++deg_v;
            }
        }
    };
    static LinkCount link_count(Worker& w) {
        const uint32_t s = w.stamp;
        w.stamp += 3;
        return {w.mark, s + 1, s + 2, s + 3};
    }
    bool topology_ok(uint32_t u, uint32_t v, size_t shared, const LinkCount& n) const;

    // collapse_engine.cpp: applying a collapse the check allowed (what both schedules share).
    // The record of the collapse w is applying (its shared_faces found), nullptr without a log.
    // Worker 0 records into records_, worker 1 into its own list (appended after a split's
    // regions).
    VertexSplit* start_record(Worker& w, uint32_t u, uint32_t v);
    // Moves the kept position v to `target` and places the attributes of its wedges: `merged`
    // where the caller found them (merged_attributes()), else interpolated along the edge. In a
    // pass without a log the placements wait in w.blends for flush_attributes(), where their
    // scattered reads overlap.
    void move_kept(Worker& w, uint32_t u, uint32_t v, const glm::dvec3& target, const WedgeMap& map,
                   VertexSplit* rec, const PendingBlend* merged);
    // Applies a placement to wedges_; flush_attributes() applies w's pending ones, in order.
    void apply_blend(const PendingBlend& b);
    void flush_attributes(Worker& w);
    void finish_collapse(Worker& w, const CollapseCandidate& c);
    // The run around a schedule: begin() once the adjacency is built (classifies, starts the cost,
    // snapshots the targets already met); after_collapse() snapshots the targets met; end() the
    // targets never reached, the stats and the log.
    void begin(std::span<const size_t> targets, std::vector<SimplifiedLevel>& levels, size_t& ti);
    void after_collapse(std::span<const size_t> targets, std::vector<SimplifiedLevel>& levels,
                        size_t& ti);
    Result<std::vector<SimplifiedLevel>> end(std::span<const size_t> targets,
                                             std::vector<SimplifiedLevel>& levels, size_t& ti);
    // The current state as an output level; `flush` brings the corners up to date first (the pass
    // schedule's pending remaps).
    virtual void flush() {}
    SimplifiedLevel snapshot();
#ifndef NDEBUG
    // Debug builds: the bookkeeping every schedule keeps (live face count, no live face on a
    // removed or repeated position, corner positions matching wedges, finite positions).
    void check_invariants() const;
#endif

    const SimplifyOptions& options_;
    CollapseCost& cost_;
    ProgressiveMesh* log_;
    const bool flat_;  // the adjacency: flat lists (true) or corner lists
    CollapseMesh m_;
    Scratch<PmWedge> wedges_;
    Scratch<glm::vec3> input_normals_;            // per face, unnormalised
    Scratch<uint32_t> wedge_first_, wedge_list_;  // per position: its wedges (CSR)
    Scratch<uint32_t> sole_wedge_;  // per position: its wedge when it has one, else kNone
    bool has_normals_ = false, has_uv0_ = false, has_uv1_ = false, has_colors_ = false;
    int material_ = -1;
    std::array<Worker, 2> workers_;
    // Runs the two halves of a split (on two threads where the caller allowed a helper).
    TwoWay two_way_;
    // The call's profile where its phases are timed (see Phase), and the time of the phases timed
    // inside the open ones.
    SimplifyProfile* profile_ = nullptr;
    double profile_nested_ms_ = 0.0;
    // The pass schedule's two regions: positions from region_start_ on are region 1 (0: no cut).
    uint32_t region_start_ = 0;
    // Whether the walks prefetch. note: under kSplitFaces the work stays on one core and its
    // arrays fit in that core's cache (about 1 MB for 8 192 faces), so the prefetches only cost
    // instructions; above it they pay (measured: docs/simplification.md, "Measurements behind the
    // engine's choices").
    bool prefetch_ = true;
    // The fold guard lets two faces fold where their input faces were folded as much (folds()):
    // for costs of the endpoints only (qem, curvature-qem), whose quadrics hold the input's
    // planes; a cost that reads the faces around an endpoint (formula1, melax) keeps the strict
    // guard.
    bool input_folds_ = false;
    // Flat lists: per position, the live faces around it (adj_ from adj_first_[p] to
    // adj_first_[p + 1]); within a pass a collapse u -> v only records remap_[u] = v and the map
    // of u's wedges (wedge_remap_), so readers map an entry's positions through remap_.
    Scratch<uint32_t> adj_first_;
    Scratch<AdjEntry> adj_;
    Scratch<uint32_t> remap_, wedge_remap_;
    // Per position (flat lists): 1 when its faces form one consistently wound fan, each neighbour
    // once as `next` and once as `prev` of its entries (so its edges are the `next`s); a collapse
    // keeps it only where both endpoints had it.
    Scratch<uint8_t> simple_fan_;
    size_t live_faces_ = 0, collapses_ = 0, initial_faces_ = 0, passes_ = 0;
    std::vector<VertexSplit> records_;
};

// The placement of a merged vertex's attributes: wedge `from` interpolated towards wedge `to` by
// t (the parameter of the new point on the edge), normals renormalised.
PmWedge lerp_wedge(const PmWedge& from, const PmWedge& to, float t, bool has_normals);

// The two schedules (greedy_schedule.cpp, pass_schedule.cpp).
Result<std::vector<SimplifiedLevel>> run_greedy_schedule(const Primitive& in,
                                                         std::span<const size_t> targets,
                                                         const SimplifyOptions& options,
                                                         CollapseCost& cost, ProgressiveMesh* log);
Result<std::vector<SimplifiedLevel>> run_pass_schedule(const Primitive& in,
                                                       std::span<const size_t> targets,
                                                       const SimplifyOptions& options,
                                                       CollapseCost& cost, ProgressiveMesh* log);

}  // namespace hmdnode::lod_detail
