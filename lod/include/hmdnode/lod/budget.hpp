// The frame-budget controller for runtime LOD (docs/lod-selection.md, "Frame budget"): a render
// cost model learned online from measured frames, a greedy benefit/cost allocator that coarsens
// the selector's levels until the predicted render fits a budget (T. A. Funkhouser, C. H. Sequin,
// "Adaptive display algorithm for interactive frame rates during visualization of complex virtual
// environments", SIGGRAPH 1993) or the immune genetic allocator of He et al. (below), and an
// integral correction of that budget from the measured render times. Full citations:
// docs/references.md.
//
// Threads: every object here belongs to the frame thread. After construction (and the allocator's
// first frames, which size its scratch) nothing allocates.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace hmdnode {

// render ms = base_ms + per_triangle_ms * triangles, fitted by exponentially weighted least
// squares over the frames seen (frame_cost_fit.cpp). Until two frames with different triangle
// counts are seen the slope is unknown and taken as the whole cost over the triangles (base 0),
// which overestimates a triangle's cost, so the allocator errs towards coarse levels.
class FrameCostFit {
  public:
    // decay: the weight of a frame one frame older (0.98: about the last 50 frames count).
    explicit FrameCostFit(double decay = 0.98);
    void add(uint64_t triangles, double render_ms);
    bool empty() const { return weight_ == 0.0; }
    double base_ms() const { return base_ms_; }
    double per_triangle_ms() const { return per_triangle_ms_; }
    double predict_ms(uint64_t triangles) const {
        return base_ms_ + per_triangle_ms_ * double(triangles);
    }

  private:
    double decay_;
    double weight_ = 0.0;  // sum of weights
    double mean_x_ = 0.0, mean_y_ = 0.0;
    double cxx_ = 0.0, cxy_ = 0.0;  // weighted co-moments about the means
    double base_ms_ = 0.0, per_triangle_ms_ = 0.0;
    bool slope_known_ = false;
};

// The budget's integral correction (budget_feedback.cpp): the allocator gets scale() x target;
// after each frame scale += gain * (target - measured) / target, clamped, and raised only when the
// allocator held detail back (a frame that wanted no more detail says nothing about the budget).
// It never raises the budget above the target: the cost model's own fit corrects an
// overestimate within a few frames, and a larger budget on top of it would overshoot the period.
struct BudgetFeedbackParams {
    double gain = 0.2;
    double min_scale = 0.25, max_scale = 1.0;
};

class BudgetFeedback {
  public:
    explicit BudgetFeedback(const BudgetFeedbackParams& params = {}) : params_(params) {}
    double scale() const { return scale_; }
    void update(double measured_ms, double target_ms, bool limited);

  private:
    BudgetFeedbackParams params_;
    double scale_ = 1.0;
};

// One drawn object as the allocator sees it.
struct BudgetCandidate {
    std::span<const double> level_errors_m;     // level 0 finest, as the selector's
    std::span<const uint64_t> level_triangles;  // same length
    // Projected error per metre of geometric error, in tolerances: pixels_per_radian /
    // (distance * tolerance_px). Level l's visible error is level_errors_m[l] * error_scale.
    double error_scale = 0.0;
    int finest = 0;  // the selector's level: the allocator never picks finer
    // The level the allocator chose for this object last frame (-1: none, e.g. newly visible):
    // the immune genetic allocator's warm start; the greedy allocator ignores it.
    int previous = -1;
};

struct BudgetAllocation {
    double predicted_ms = 0.0;  // base + per_triangle * triangles of the chosen levels
    uint64_t triangles = 0;
    size_t coarsened = 0;  // objects left coarser than the selector's level
    bool limited = false;  // the budget held some upgrade back
};

// Funkhouser & Sequin 1993: every object starts at its coarsest level; the upgrade with the best
// benefit (visible error removed, in tolerances) per predicted ms is applied while the prediction
// fits the budget, up to the selector's level. A heap of one candidate upgrade per object:
// O(n L^2 + n L log n) for n objects of L levels (greedy_allocator.cpp).
class GreedyLodAllocator {
  public:
    // Writes each candidate's level to levels[i] (levels.size() == candidates.size()).
    BudgetAllocation allocate(std::span<const BudgetCandidate> candidates, double base_ms,
                              double per_triangle_ms, double budget_ms, std::span<int> levels);

  private:
    struct Step {
        double ratio;  // benefit per ms (infinity: free)
        uint32_t object;
        int to;
    };
    std::vector<Step> heap_;
};

// The immune genetic algorithm of J. He, P. Wang, J. Zhu, J. Zeng, "Application and Optimization of
// Mesh Simplification in 3D virtual Reality Scene in a High-performance Environment" (venue and
// year not stated in our copy), section 2.2 (3), as a second allocator: an antibody is a level per
// object, its affinity 1/f^2 of f = the visible error left (in tolerances, the greedy's benefit
// model), kept within the budget by repair; selection by affinity and antibody concentration,
// arithmetic crossover (eq. 17), random-reset mutation (eq. 18), a vaccine from the best
// antibodies' mean genes, the best kept as memory cell; warm-started from last frame's levels
// (BudgetCandidate::previous). Deterministic: the generator is reseeded from `seed` on every call,
// and the work is capped by generations, never by a clock. The greedy's answer is one initial
// antibody. O(G P n L) for G generations of P antibodies over n objects of L levels, plus the
// greedy's cost (iga_allocator.cpp).
struct IgaParams {
    int population = 8;            // antibodies (>= 4)
    int max_generations = 8;       // hard cap: the decision time is bounded by it
    int stall_generations = 2;     // stop early after this many generations without a better one
    double crossover_p = 0.8;      // per pair of parents (eq. 17)
    double mutations = 2.0;        // expected random-reset genes per antibody (eq. 18)
    double vaccine_p = 0.5;        // per child: vaccinated or not
    double vaccine_genes = 0.05;   // fraction of a vaccinated child's genes set to the vaccine's
    int vaccine_donors = 3;        // the vaccine is the mean of the best few antibodies' genes
    double affinity_weight = 0.7;  // selection: this x affinity share + rest x 1/concentration
    double similar = 0.01;         // two antibodies are alike when their f differ by <= this
    double keep_previous = 0.005;  // last frame's levels stay unless beaten by more than this
    uint64_t seed = 0x1da2021;     // same input + same seed -> same levels
};

class IgaLodAllocator {
  public:
    using Gene = uint16_t;  // a level
    explicit IgaLodAllocator(const IgaParams& params = {}) : params_(params) {}
    // As GreedyLodAllocator::allocate; candidates' `previous` warm-starts the search.
    BudgetAllocation allocate(std::span<const BudgetCandidate> candidates, double base_ms,
                              double per_triangle_ms, double budget_ms, std::span<int> levels);
    int last_generations() const { return generations_; }  // of the last allocate()

  private:
    struct Antibody {
        double f = 0.0;  // visible error left, in tolerances (to minimise)
        uint64_t triangles = 0;
    };
    struct Run;  // the steps of one allocate() call (iga_allocator.cpp)
    IgaParams params_;
    int generations_ = 0;
    GreedyLodAllocator greedy_;  // its answer is one initial antibody
    std::vector<int> greedy_levels_;
    // Scratch, sized by the first frames.
    std::vector<Gene> genes_, children_, vaccine_, warm_, finest_, coarsest_;
    std::vector<Antibody> antibodies_, child_antibodies_;
    std::vector<uint32_t> order_;  // objects by benefit per ms of their whole range, ascending
    std::vector<double> density_, select_p_, affinity_, inv_concentration_;
    std::vector<uint32_t> parents_, ranked_;
};

}  // namespace hmdnode
