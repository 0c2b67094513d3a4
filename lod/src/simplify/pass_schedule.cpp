// The pass schedule, for costs of the endpoints only (qem, curvature-qem): passes in the manner
// of meshoptimizer's simplifier (A. Kapoulkine).
//
// Method: at the start of every pass the live faces around each position are laid out as one
// flat array (CSR) of (next, prev, corner) entries, in O(F). Within the pass a collapse u -> v
// only records remap_[u] = v and the map of u's wedges; a walk maps each entry's positions through
// remap_ (one step: a kept position is not removed in the same pass, and a face is dead when its
// other two positions now coincide), and the face corners are rewritten once, before the next pass
// or a snapshot. A free position whose faces form one consistently wound fan has its edges listed
// from its flat list alone. Each pass sorts the candidates (one per edge: the cheaper allowed
// direction, or a merge at a new point) by the top 22 bits of the float cost (costs within a
// relative 2^-13 keep their previous order: a radix pass on the top 11 bits, then counting or
// insertion sorts of only the buckets the pass reads) and applies them in order while neither
// endpoint was touched earlier in the pass, up to 1.5 times the cost of the k-th cheapest (k =
// collapses still needed) or, where that made fewer than k/8 collapses (piecewise-flat input,
// where most candidates cost zero and many fail the checks), until it has made k/8; within 256
// collapses of a target, up to 4 times the current cost of the cheapest candidate it had to skip.
// The next pass drops the candidates of touched positions and evaluates their edges again. Within
// a pass the order is greedy and every applied cost is exact (a QEM cost reads only its two
// quadrics). The check is collapse_check.hpp's, in one walk of each endpoint's flat list; the
// sort is candidate_sort.cpp's; the class, pass_schedule.hpp.
//
// The split: from kSplitFaces input faces on, the positions are cut at the median of the bounding
// box's longest axis into two regions numbered apart (collapse_mesh.cpp); while at least
// kSplitGoal collapses are left to the next target, a pass applies the candidates whose endpoints
// have all their faces in one region region by region (each in cost order, neither reading what
// the other writes, at most a quarter of the faces left to the target each, so no target falls
// inside), then the candidates across the cut in cost order; the evaluation of the candidates
// splits by halves of the positions, the sort by halves of the candidates, the attribute
// interpolations and the dropping of stale candidates run beside the adjacency rebuild. The two
// halves run on the helper thread (two_way.hpp) only where the caller allows a second thread; the
// result is the same bit for bit either way.
//
// Cost: O(E) per pass, a handful to a few dozen passes; memory: the flat lists (rebuilt per pass),
// 40 bytes per candidate and 16 for its sort keys.
#include <algorithm>
#include <cassert>
#include <cstring>
#include <limits>
#include <thread>

#include "collapse_check.hpp"
#include "collapse_mesh.hpp"
#include "merge_attributes.hpp"
#include "pass_schedule.hpp"

namespace hmdnode::lod_detail {

Result<std::vector<SimplifiedLevel>> PassSchedule::run(const Primitive& in,
                                                       std::span<const size_t> targets) {
    prefetch_ = in.indices.size() / 3 >= kSplitFaces;
    std::vector<SimplifiedLevel> levels;
    size_t ti = 0;
    {
        const Phase phase(*this, &SimplifyProfile::setup_ms);
        build(in);
        remap_.resize(m_.positions.size());
        for (uint32_t p = 0; p < uint32_t(remap_.size()); ++p) remap_[p] = p;
        wedge_remap_.resize(m_.wedge_position.size());
        for (uint32_t w = 0; w < uint32_t(wedge_remap_.size()); ++w) wedge_remap_[w] = w;
        for (uint32_t f = 0; f < uint32_t(m_.face_alive.size()); ++f) {
            if (m_.face_alive[f]) live_list_.push_back(f);
        }
        {
            const Phase adjacency(*this, &SimplifyProfile::adjacency_ms);
            rebuild_adjacency();
        }
        begin(targets, levels, ti);
    }
    run_passes(targets, levels, ti);
    const Phase phase(*this, &SimplifyProfile::other_ms);
    return end(targets, levels, ti);
}

void PassSchedule::flush() {
    if (!pending_remap_) return;
    pending_remap_ = false;
    for (Worker& w : workers_) flush_attributes(w);
    for (uint32_t f : live_list_) {
        if (m_.face_alive[f]) remap_corners(f);
    }
}

void PassSchedule::rebuild_adjacency() {
    // note: flush(), the pruning of dead faces and
    // the count of the entries in one walk (the rewrite is the identity where nothing is pending).
    pending_remap_ = false;
    const uint32_t np = uint32_t(m_.positions.size());
    adj_first_.assign(np + 1, 0);
    size_t kept = 0;
    for (uint32_t f : live_list_) {
        if (!m_.face_alive[f]) continue;
        live_list_[kept++] = f;
        remap_corners(f);
        for (uint32_t c = 3 * f; c < 3 * f + 3; ++c) ++adj_first_[m_.corner_position[c] + 1];
    }
    live_list_.resize(kept);
    for (uint32_t p = 0; p < np; ++p) adj_first_[p + 1] += adj_first_[p];
    adj_.resize(adj_first_[np]);
    const uint32_t cut = region_start_;
    if (cut > 0) {
        region_class_.resize(np);
        for (uint32_t p = 0; p < np; ++p) region_class_[p] = p < cut ? 1 : 2;
    }
    const size_t live = live_list_.size();
    for (size_t i = 0; i < live; ++i) {
        if (prefetch_ && i + 8 < live) {
            // note: the entries are written scattered; fetch their lines a few faces ahead
            const uint32_t g = live_list_[i + 8];
            for (uint32_t c = 3 * g; c < 3 * g + 3; ++c) {
                __builtin_prefetch(&adj_[adj_first_[m_.corner_position[c]]], 1);
            }
        }
        const uint32_t f = live_list_[i];
        const uint32_t p0 = m_.corner_position[3 * f], p1 = m_.corner_position[3 * f + 1],
                       p2 = m_.corner_position[3 * f + 2];
        adj_[adj_first_[p0]++] = {p1, p2, 3 * f};
        adj_[adj_first_[p1]++] = {p2, p0, 3 * f + 1};
        adj_[adj_first_[p2]++] = {p0, p1, 3 * f + 2};
        if (cut > 0 && ((p0 < cut) != (p1 < cut) || (p1 < cut) != (p2 < cut))) {
            region_class_[p0] = region_class_[p1] = region_class_[p2] = 3;
        }
    }
    for (uint32_t p = np; p > 0; --p) adj_first_[p] = adj_first_[p - 1];
    adj_first_[0] = 0;
#ifndef NDEBUG
    check_adjacency();
#endif
}

// One candidate per live edge: the edges of every position, each from its lower endpoint. The
// positions split in two halves by id; the second half's candidates follow the first's, as they
// would in one loop.
void PassSchedule::collect_candidates() {
    candidates_.clear();
    const uint32_t np = uint32_t(m_.positions.size());
    // note: in one piece without a helper (the same order).
    const uint32_t cut = two_way_.has_helper() ? np / 2 : np;
    auto half = [this, cut, np](int h) {  // note: by value (two_way.hpp)
        Worker& w = workers_[h];
        // note: appended through a vector on this thread's stack: the other thread reads lines
        // of this object, and writing the vector's end here would keep evicting them.
        Scratch<Candidate> out;
        out.swap(h == 0 ? candidates_ : halves_[1].candidates);
        const uint32_t begin = h == 0 ? 0 : cut, end = h == 0 ? cut : np;
        for (uint32_t p = begin; p < end; ++p) {
            if (p + 2 < end) prefetch_neighbours(p + 2);
            if (m_.position_alive[p]) add_candidates(w, p, kNone, out);
        }
        out.swap(h == 0 ? candidates_ : halves_[1].candidates);
    };
    // note: reserved here, from this thread's scratch cache (pages mapped by earlier runs); an
    // upper bound: one candidate per half-edge.
    halves_[1].candidates.clear();
    halves_[1].candidates.reserve(adj_first_[np] - adj_first_[cut] + 16);
    two_way_.run(half);
    candidates_.insert(candidates_.end(), halves_[1].candidates.begin(),
                       halves_[1].candidates.end());
}

// Candidates of the edges of p, appended to `out`; an edge whose other end q is also being
// refreshed (refresh_mark_[q] == refresh) is left to the lower of the two.
void PassSchedule::add_candidates(Worker& w, uint32_t p, uint32_t refresh,
                                  Scratch<Candidate>& out) {
    if (simple_fan_[p] && m_.kinds[p] == VertexKind::Free) {
        // note: a free position's edges are interior and no seam: p may always be removed, q
        // when it is free too (then both may merge).
        for (uint32_t i = adj_first_[p], end = adj_first_[p + 1]; i < end; ++i) {
            const uint32_t q = adj_[i].next;
            if (refresh == kNone ? q < p : (refresh_mark_[q] == refresh && q < p)) continue;
            const bool q_free = m_.kinds[q] == VertexKind::Free;
            CollapseCandidate c;
            if (cost_.evaluate(m_, p, q, {true, q_free, q_free}, c)) out.emplace_back(c);
        }
        return;
    }
    gather_edges(w, p);
    for (const EdgeGroup& g : w.groups) {
        if (refresh == kNone ? g.q < p : (refresh_mark_[g.q] == refresh && g.q < p)) continue;
        if (m_.kinds[p] == VertexKind::Locked && m_.kinds[g.q] == VertexKind::Locked) continue;
        const EdgeMoves moves = moves_for(p, g.q, int(g.count), g.wp, g.wq);
        if (!moves.a_to_b && !moves.b_to_a) continue;
        CollapseCandidate c;
        if (cost_.evaluate(m_, p, g.q, moves, c)) out.emplace_back(c);
    }
}

// After a pass: drops the candidates whose endpoints a collapse touched. Untouched candidates keep
// their cost: a QEM-type cost reads only the endpoints' quadrics and positions.
void PassSchedule::drop_touched_candidates() {
    // note: a touched position (the kept one) is alive; a dead one (removed) was touched in the
    // pass that removed it, or earlier, when its candidates were dropped. Branch-free: kept or not
    // is close to a coin toss.
    size_t kept = 0;
    for (const Candidate& c : candidates_) {
        candidates_[kept] = c;
        kept += size_t(touched_[c.from] != touched_pass_) & size_t(touched_[c.to] != touched_pass_);
    }
    candidates_.resize(kept);
}

// After drop_touched_candidates(): fresh candidates for the edges of the touched positions (the
// touched list split in two halves, the second half's candidates after the first's).
void PassSchedule::refresh_candidates() {
    const uint32_t r = ++refresh_stamp_;
    for (uint32_t v : touched_list_) refresh_mark_[v] = r;
    const size_t nt = touched_list_.size();
    const size_t cut = two_way_.has_helper() ? nt / 2 : nt;  // note: see collect_candidates()
    auto half = [this, r, cut, nt](int h) {
        Worker& w = workers_[h];
        Scratch<Candidate> out;  // note: see collect_candidates()
        out.swap(h == 0 ? candidates_ : halves_[1].candidates);
        const size_t begin = h == 0 ? 0 : cut, end = h == 0 ? cut : nt;
        for (size_t i = begin; i < end; ++i) {
            if (prefetch_ && i + 8 < end) __builtin_prefetch(&adj_first_[touched_list_[i + 8]]);
            if (i + 4 < end) prefetch_list(touched_list_[i + 4]);
            if (i + 2 < end) prefetch_neighbours(touched_list_[i + 2]);
            const uint32_t v = touched_list_[i];
            if (m_.position_alive[v]) add_candidates(w, v, r, out);
        }
        out.swap(h == 0 ? candidates_ : halves_[1].candidates);
    };
    halves_[1].candidates.clear();
    two_way_.run(half);
    candidates_.insert(candidates_.end(), halves_[1].candidates.begin(),
                       halves_[1].candidates.end());
    touched_list_.clear();
}

// Costs of the endpoints only (QEM): passes in the manner of meshoptimizer. Each pass evaluates
// every edge, sorts the candidates (radix sort on the top 22 bits of the costs), and applies them
// in order of cost while neither endpoint was touched earlier in the pass (their cost is still
// exact), up to the cost of the k-th cheapest times 1.5, k = the collapses still needed for the
// next target (many candidates get skipped as touched). Order is greedy within a pass; a pass is
// O(E).
//
// Far from a target (at least kSplitGoal collapses to go) a pass splits in two: the positions are
// cut in two regions at the median of the longest axis, once; a candidate whose endpoints have
// all their faces inside one region is applied by that region's worker (each in cost order, on
// two threads where there is a helper: their collapses read and write only positions and faces of
// their own region), at most a quarter of the faces still to remove each, so that no target is
// passed; then the candidates across the cut follow, in cost order, on this thread.
void PassSchedule::run_passes(std::span<const size_t> targets, std::vector<SimplifiedLevel>& levels,
                              size_t& ti) {
    touched_.assign(m_.positions.size(), 0);
    uint32_t pass = 0;
    refresh_mark_.assign(m_.positions.size(), 0);
    // note: at most one candidate per half-edge (more than 3F/2 edges with open borders); pages
    // never written are never touched.
    candidates_.reserve(adj_.size() + 16);
    {
        const Phase phase(*this, &SimplifyProfile::candidates_ms);
        collect_candidates();
    }
    while (ti < targets.size()) {
        if (pass > 0) {
            // note: the attribute placements and the dropping of stale candidates (the helper)
            // while this thread rebuilds the adjacency: disjoint data.
            touched_pass_ = pass;
            auto prepare = [this](int h) {
                if (h == 0) {
                    const Phase phase(*this, &SimplifyProfile::adjacency_ms);
                    rebuild_adjacency();
                } else {
                    for (Worker& w : workers_) flush_attributes(w);
                    const Phase phase(*this, &SimplifyProfile::candidates_ms);
                    drop_touched_candidates();
                }
            };
            two_way_.run(prepare);
            const Phase phase(*this, &SimplifyProfile::candidates_ms);
            refresh_candidates();
        }
        const size_t n = candidates_.size();
        if (n == 0) break;
        // note: the region classes ride in the top two bits of the candidate index.
        const bool classes = region_start_ > 0 && n < (size_t(1) << 30);
        const size_t goal = (live_faces_ - targets[ti] + 1) / 2;
        double limit;
        {
            const Phase phase(*this, &SimplifyProfile::sort_ms);
            limit = sort_candidates(classes, goal);
        }
        const Phase apply(*this, &SimplifyProfile::apply_ms);
        ++pass;
        passes_ = pass;
        // A pass goes past its limit until it has made an eighth of the collapses the target
        // needs: candidates up to the limit that fail the checks stay in the list with their
        // costs, and where they are most of those up to the goal-th (flat input, where many cost
        // zero) the limit would allow a handful of collapses per O(E) pass.
        const size_t min_done = std::max<size_t>(1, goal / 8);
        size_t done = 0;
        if (classes && goal >= kSplitGoal) {
            done = split_pass(pass, limit, targets[ti]);
            for (size_t i = 0; i < done; ++i) after_collapse(targets, levels, ti);
            done += boundary_pass(pass, targets, levels, ti);
            if (done >= min_done || ti == targets.size()) continue;
        }
        double skipped = std::numeric_limits<double>::infinity();
        for (size_t i = 0; i < n && ti < targets.size(); ++i) {
            if (i == sorted_) {
                const Phase phase(*this, &SimplifyProfile::sort_ms);
                sort_rest();
            }
            prefetch_ahead(order_.data(), i, n);
            const CollapseCandidate c = candidate_at(i).unpack();
            if (c.cost > limit && done >= min_done) break;
            // note: close to a target (few collapses left), a candidate skipped because an
            // endpoint was touched may now cost less than the ones that follow, and going past
            // 4 times its cost would run ahead of it (a cube would lose a corner); far from a
            // target the 1.5 x limit suffices. Its cost now, from the current quadrics and
            // positions (a QEM-type cost reads nothing else): with its stale cost, a lower bound
            // (and 8 times it), the fandisk's last passes at 10 % made one collapse each.
            if (goal < 256 && c.cost > 4.0 * skipped) break;
            if (touched_[c.from] == pass || touched_[c.to] == pass) {
                if (goal < 256) skipped = std::min(skipped, cost_now(c));
                continue;
            }
            done += apply_in_pass(c, pass, targets, levels, ti);
        }
        if (done == 0) break;
    }
}

// The two regions' share of a pass (see run_passes()): the sorted candidates up to `limit` go to
// their region's worker or, across the cut, to boundary_; returns the collapses applied.
size_t PassSchedule::split_pass(uint32_t pass, double limit, size_t target) {
    const size_t n = order_.size();
    boundary_.clear();
    for (Half& half : halves_) {
        half.order.clear();
        half.touched.clear();
        half.collapses = half.removed_faces = 0;
    }
    for (size_t i = 0; i < n; ++i) {
        const uint64_t item = order_[i];
        float cost;
        const uint32_t key = uint32_t(item >> 32);
        std::memcpy(&cost, &key, 4);
        if (double(cost) > limit) break;
        const uint32_t cls = uint32_t(item >> 30) & 3;
        (cls == 1 ? halves_[0].order : cls == 2 ? halves_[1].order : boundary_).push_back(item);
    }
    // note: each collapse removes at most two faces; a quarter of the way to the target each
    // leaves the target ahead.
    const size_t cap = (live_faces_ - target - 1) / 4;
    for (int h = 0; h < 2; ++h) {
        // note: reserved on this thread, from its scratch cache (pages mapped by earlier runs).
        const size_t most = std::min(halves_[h].order.size(), cap);
        halves_[h].touched.reserve(most);
    }
    auto region = [this, pass, cap](int h) {
        Worker& w = workers_[h];
        Half& half = halves_[h];
        const size_t count = half.order.size();
        for (size_t i = 0; i < count && half.collapses < cap; ++i) {
            prefetch_ahead(half.order.data(), i, count);
            const CollapseCandidate c =
                candidates_[uint32_t(half.order[i]) & kCandidateIndex].unpack();
            if (touched_[c.from] == pass || touched_[c.to] == pass) continue;
            // note: a region's collapse reads and writes only its own region's positions
            assert(region_class_[c.from] == uint8_t(h + 1) &&
                   region_class_[c.to] == uint8_t(h + 1));
            const size_t removed = try_collapse_in_pass(w, c);
            if (removed == 0) continue;
            touched_[c.from] = touched_[c.to] = pass;
            half.touched.push_back(c.to);
            half.removed_faces += removed;
            ++half.collapses;
        }
    };
    two_way_.run(region);
    size_t done = 0;
    for (Half& half : halves_) {
        live_faces_ -= half.removed_faces;
        touched_list_.insert(touched_list_.end(), half.touched.begin(), half.touched.end());
        done += half.collapses;
    }
    // note: region 0's collapses (already in records_), then region 1's: an order in which they
    // could have run one by one (the regions share nothing).
    records_.insert(records_.end(), std::make_move_iterator(workers_[1].records.begin()),
                    std::make_move_iterator(workers_[1].records.end()));
    workers_[1].records.clear();
    if (done > 0) pending_remap_ = true;
    return done;
}

// The candidates across the cut, after split_pass(), in cost order on this thread.
size_t PassSchedule::boundary_pass(uint32_t pass, std::span<const size_t> targets,
                                   std::vector<SimplifiedLevel>& levels, size_t& ti) {
    // note: a collapse across the cut reads wedges of both regions: their placements first.
    for (Worker& w : workers_) flush_attributes(w);
    size_t done = 0;
    const size_t count = boundary_.size();
    for (size_t i = 0; i < count && ti < targets.size(); ++i) {
        prefetch_ahead(boundary_.data(), i, count);
        const CollapseCandidate c = candidates_[uint32_t(boundary_[i]) & kCandidateIndex].unpack();
        if (touched_[c.from] == pass || touched_[c.to] == pass) continue;
        done += apply_in_pass(c, pass, targets, levels, ti);
    }
    return done;
}

// One collapse of a pass on this thread (outside a split's regions); false when refused.
// note: inlined into its callers (a call per collapse costs about 50 instructions).
[[gnu::always_inline]] inline bool PassSchedule::apply_in_pass(const CollapseCandidate& c,
                                                               uint32_t pass,
                                                               std::span<const size_t> targets,
                                                               std::vector<SimplifiedLevel>& levels,
                                                               size_t& ti) {
    const size_t removed = try_collapse_in_pass(workers_[0], c);
    if (removed == 0) return false;
    live_faces_ -= removed;
    pending_remap_ = true;
    touched_[c.from] = touched_[c.to] = pass;
    touched_list_.push_back(c.to);
    after_collapse(targets, levels, ti);
    return true;
}

// note: the walks of a collapse read faces scattered over the corner arrays; fetch the candidates,
// then their flat lists, then their faces, a few steps ahead (no effect on the result).
void PassSchedule::prefetch_ahead(const uint64_t* order, size_t i, size_t n) const {
    if (!prefetch_) return;
    auto at = [&](size_t k) -> const Candidate& {
        return candidates_[uint32_t(order[k]) & kCandidateIndex];
    };
    if (i + 16 < n) __builtin_prefetch(&at(i + 16));
    if (i + 8 < n) {
        const Candidate& a = at(i + 8);
        __builtin_prefetch(&adj_first_[a.from]);
        __builtin_prefetch(&adj_first_[a.to]);
        __builtin_prefetch(&touched_[a.from]);
        __builtin_prefetch(&touched_[a.to]);
    }
    if (i + 4 < n) {
        const Candidate& a = at(i + 4);
        prefetch_list(a.from);
        prefetch_list(a.to);
        // note: what applying it reads of the cost (a QEM-type cost: both quadrics)
        cost_.prefetch(a.from);
        cost_.prefetch(a.to);
    }
    if (i + 2 < n) {
        const Candidate& a = at(i + 2);
        prefetch_faces(a.from);
        prefetch_faces(a.to);
    }
}

// The cost of candidate c's collapse with the quadrics and positions of now (its endpoints
// touched earlier in this pass, so possibly no longer an edge: a bound for run_passes()'s end
// game); infinity when an endpoint was removed.
double PassSchedule::cost_now(const CollapseCandidate& c) {
    if (!m_.position_alive[c.from] || !m_.position_alive[c.to]) {
        return std::numeric_limits<double>::infinity();
    }
    CollapseCandidate now;
    const EdgeMoves moves = c.moves ? EdgeMoves{false, false, true} : EdgeMoves{true, false, false};
    if (!cost_.evaluate(m_, c.from, c.to, moves, now))
        return std::numeric_limits<double>::infinity();
    return now.cost;
}

// The pass's collapse: the check on the flat lists (entries mapped through remap_), in one walk of
// each endpoint; u and v were not touched earlier in the pass, so their lists are current and
// every face in them is live unless its other two positions now coincide. Applying only records
// the remaps; flush() rewrites the corners. The caller counts the faces removed and marks the
// remaps pending.
[[gnu::flatten]] size_t PassSchedule::try_collapse_in_pass(Worker& w, const CollapseCandidate& c) {
    WedgeMap map;
    auto around = [this](uint32_t p, auto&& f) {
        for (uint32_t i = adj_first_[p], end = adj_first_[p + 1]; i < end; ++i) {
            const AdjEntry& e = adj_[i];
            const uint32_t a = remap_[e.next], b = remap_[e.prev];
            if (a == b) continue;  // collapsed earlier in the pass
            const uint32_t face = e.corner / 3;
            if (!f(face, e.corner - 3 * face, a, b)) return;
        }
    };
    const size_t shared = check_collapse(w, c, map, around);
    if (shared == 0) return 0;
    const uint32_t u = c.from, v = c.to;
    const glm::dvec3 target = c.moves ? c.position : glm::dvec3(m_.positions[v]);
    const Scratch<uint32_t>& shared_faces = w.shared_faces;

    // Apply: the faces on the edge die, u maps to v and its wedges to v's (the corners are
    // rewritten by flush()).
    VertexSplit* rec = start_record(w, u, v);
    if (rec) {
        for (uint32_t i = adj_first_[u], end = adj_first_[u + 1]; i < end; ++i) {
            const uint32_t f = adj_[i].corner / 3;
            if (!m_.face_alive[f]) continue;
            if (std::find(shared_faces.begin(), shared_faces.end(), f) != shared_faces.end()) {
                continue;
            }
            rec->corners.push_back({adj_[i].corner, m_.corners[adj_[i].corner]});
        }
    }
    if (c.moves) {
        PendingBlend merged;
        const bool in_face =
            map.count == 1 && merges_free(u, v) &&
            merged_attributes(
                u, v, target, around, [this](uint32_t cr) { return wedge_remap_[m_.corners[cr]]; },
                merged);
        move_kept(w, u, v, target, map, rec, in_face ? &merged : nullptr);
    }
    for (uint32_t f : shared_faces) m_.face_alive[f] = 0;
    for (int i = 0; i < map.count; ++i) wedge_remap_[map.from[i]] = map.to[i];
    remap_[u] = v;
    simple_fan_[v] &= simple_fan_[u];
    m_.position_alive[u] = 0;
    finish_collapse(w, c);
    return shared;
}

#ifndef NDEBUG
// After rebuild_adjacency(): every entry of p's flat list is a live face at p's corner, wound as
// (p, next, prev), and the entries count three per live face.
void PassSchedule::check_adjacency() const {
    const uint32_t np = uint32_t(m_.positions.size());
    assert(adj_first_[np] == 3 * live_list_.size());
    for (uint32_t p = 0; p < np; ++p) {
        for (uint32_t i = adj_first_[p]; i < adj_first_[p + 1]; ++i) {
            const AdjEntry& e = adj_[i];
            const uint32_t f = e.corner / 3, k = e.corner % 3;
            assert(m_.face_alive[f] && m_.position_alive[p]);
            assert(m_.corner_position[e.corner] == p);
            assert(m_.face_position(f, (k + 1) % 3) == e.next);
            assert(m_.face_position(f, (k + 2) % 3) == e.prev);
            (void)f, (void)k, (void)e;
        }
    }
}
#endif

Result<std::vector<SimplifiedLevel>> run_pass_schedule(const Primitive& in,
                                                       std::span<const size_t> targets,
                                                       const SimplifyOptions& options,
                                                       CollapseCost& cost, ProgressiveMesh* log) {
    // note: the regions are cut the same with or without the helper (the same output); the
    // helper runs only where the caller allowed a second thread and it pays.
    const bool helper = options.threads >= 2 && in.indices.size() / 3 >= kHelperFaces &&
                        std::thread::hardware_concurrency() > 1;
    PassSchedule schedule(options, cost, log, helper);
    return schedule.run(in, targets);
}

}  // namespace hmdnode::lod_detail
