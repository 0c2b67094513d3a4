// The pass schedule's class (pass_schedule.cpp: the passes; candidate_sort.cpp: the sort of the
// candidates by cost). Private to those two files.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "collapse_mesh.hpp"

namespace hmdnode::lod_detail {

// From this many input faces on, a caller's second thread (SimplifyOptions::threads >= 2) runs
// the halves of a split; below it everything runs on the calling thread. It is the split's own
// threshold: below kSplitFaces there is nothing to split.
inline constexpr size_t kHelperFaces = kSplitFaces;

class PassSchedule final : public EngineCore {
  public:
    PassSchedule(const SimplifyOptions& options, CollapseCost& cost, ProgressiveMesh* log,
                 bool helper)
        : EngineCore(options, cost, log, /*flat_lists=*/true, helper) {}

    Result<std::vector<SimplifiedLevel>> run(const Primitive& in, std::span<const size_t> targets);

  private:
    // A CollapseCandidate packed into 40 bytes (the pass loop reads them in cost order).
    struct Candidate {
        float cost;
        uint32_t from, to;
        glm::vec3 position;
        float error;
        bool moves;

        Candidate() = default;
        explicit Candidate(const CollapseCandidate& c)
            : cost(float(c.cost)),
              from(c.from),
              to(c.to),
              position(c.position),
              error(float(c.error)),
              moves(c.moves) {}
        CollapseCandidate unpack() const {
            return {double(cost), from, to, moves, glm::dvec3(position), double(error)};
        }
    };
    // What one half of a split pass works with besides its Worker (workers_[h]). note: aligned
    // apart, as Worker is.
    struct alignas(128) Half {
        Scratch<Candidate> candidates;  // the second half's new candidates
        // A region's share of a pass: its candidates in cost order, the positions its collapses
        // kept, the faces they removed.
        Scratch<uint64_t> order;
        Scratch<uint32_t> touched;
        size_t collapses = 0, removed_faces = 0;
        // sort_candidates(): the counts and offsets of this half's radix buckets
        Scratch<uint32_t> radix;
    };

    void rebuild_adjacency();
    // Rewrites the corners of the live faces through the remaps of the pass.
    void flush() override;
    // Face f's corners through the remaps of the pass.
    void remap_corners(uint32_t f) {
        for (uint32_t c = 3 * f; c < 3 * f + 3; ++c) {
            m_.corners[c] = wedge_remap_[m_.corners[c]];
            m_.corner_position[c] = remap_[m_.corner_position[c]];
        }
    }
#ifndef NDEBUG
    void check_adjacency() const;
#endif
    // The walks of p: its flat list, then its faces (no effect on the result).
    void prefetch_list(uint32_t p) const {
        if (prefetch_) __builtin_prefetch(adj_.data() + adj_first_[p]);
    }
    void prefetch_faces(uint32_t p) const {
        for (uint32_t i = adj_first_[p], end = adj_first_[p + 1]; i < end; ++i) {
            const AdjEntry& e = adj_[i];
            __builtin_prefetch(&m_.positions[e.next]);
            __builtin_prefetch(&m_.corners[e.corner]);
            __builtin_prefetch(&input_normals_[e.corner / 3]);
        }
    }
    // What evaluating the edges of p reads about its neighbours.
    void prefetch_neighbours(uint32_t p) const {
        if (!prefetch_) return;
        for (uint32_t i = adj_first_[p], end = adj_first_[p + 1]; i < end; ++i) {
            const uint32_t q = adj_[i].next;
            __builtin_prefetch(&m_.positions[q]);
            __builtin_prefetch(&m_.kinds[q]);
            cost_.prefetch(q);
        }
    }
    void collect_candidates();
    void add_candidates(Worker& w, uint32_t p, uint32_t refresh, Scratch<Candidate>& out);
    void drop_touched_candidates();
    void refresh_candidates();
    void run_passes(std::span<const size_t> targets, std::vector<SimplifiedLevel>& levels,
                    size_t& ti);
    size_t split_pass(uint32_t pass, double limit, size_t target);
    size_t boundary_pass(uint32_t pass, std::span<const size_t> targets,
                         std::vector<SimplifiedLevel>& levels, size_t& ti);
    bool apply_in_pass(const CollapseCandidate& c, uint32_t pass, std::span<const size_t> targets,
                       std::vector<SimplifiedLevel>& levels, size_t& ti);
    // The faces the collapse removed (1 or 2), 0 when refused.
    size_t try_collapse_in_pass(Worker& w, const CollapseCandidate& c);
    void prefetch_ahead(const uint64_t* order, size_t i, size_t n) const;
    double cost_now(const CollapseCandidate& c);
    double sort_candidates(bool classes, size_t goal);
    void sort_buckets(uint32_t first, uint32_t last, uint32_t skip);
    void sort_bucket(uint32_t b, uint32_t* counts);
    void sort_rest();
    const Candidate& candidate_at(size_t rank) const {
        return candidates_[uint32_t(order_[rank]) & kCandidateIndex];
    }

    std::array<Half, 2> halves_;
    Scratch<Candidate> candidates_;
    // Per position: the last pass in which a collapse touched it (the candidates of its edges are
    // then evaluated again before the next pass).
    Scratch<uint32_t> touched_;
    uint32_t touched_pass_ = 0;
    Scratch<uint32_t> touched_list_, refresh_mark_;
    uint32_t refresh_stamp_ = 0;
    Scratch<uint32_t> keys_;  // the candidates' cost bits, read twice by sort_candidates()
    // (cost key << 32 | region class << 30 | candidate), in cost order
    Scratch<uint64_t> order_, order_tmp_;
    static constexpr uint32_t kCandidateIndex = (uint32_t(1) << 30) - 1;
    static constexpr uint32_t kRadixBuckets = 2048;      // 11 bits
    static constexpr uint32_t kInsertionSortItems = 64;  // see sort_bucket()
    // sort_candidates(): where each high bucket starts in order_ (and order_tmp_), and the items
    // sorted, up to a bucket's start (order_ from sorted_ on holds the rest unsorted).
    std::array<uint32_t, kRadixBuckets + 1> bucket_start_{};
    size_t sorted_ = 0;
    // Per position and pass: 1 or 2 when all its faces lie in region 0 or 1, 3 otherwise.
    Scratch<uint8_t> region_class_;
    Scratch<uint64_t> boundary_;   // the candidates across the cut, in cost order
    Scratch<uint32_t> live_list_;  // the faces live at the last rebuild_adjacency()
    bool pending_remap_ = false;
};

}  // namespace hmdnode::lod_detail
