// The LOD decision benches' scene (bench_lod_budget_bench, bench_lod_allocator_bench): n objects
// of 4-6 levels scattered within 30 m of a viewer, each level a quarter of the triangles and four
// times the error of the one before, and a viewer turning 0.01 rad per frame at a head speed that
// cycles 0-180 deg/s. Header-only, deterministic (seed 21).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "hmdnode/lod/budget.hpp"
#include "hmdnode/lod/selector.hpp"

namespace hmdnode::bench {

struct DecisionObject {
    glm::dvec3 center;
    double radius;
    std::vector<double> errors;
    std::vector<uint64_t> triangles;
};

inline std::vector<DecisionObject> decision_objects(size_t n) {
    std::mt19937 rng(21);
    std::uniform_real_distribution<double> pos(-30.0, 30.0), radius(0.2, 2.0);
    std::uniform_int_distribution<int> levels_d(4, 6), tri_d(2000, 200000);
    std::vector<DecisionObject> objects(n);
    for (DecisionObject& o : objects) {
        o.center = {pos(rng), pos(rng) * 0.2, pos(rng)};
        o.radius = radius(rng);
        const int levels = levels_d(rng);
        const uint64_t t0 = uint64_t(tri_d(rng));
        for (int l = 0; l < levels; ++l) {
            o.errors.push_back(l == 0 ? 0.0 : o.radius * 0.002 * double(1 << (2 * (l - 1))));
            o.triangles.push_back(std::max<uint64_t>(8, t0 >> (2 * l)));
        }
    }
    return objects;
}

inline LodViewer decision_viewer(int frame) {
    LodViewer v;
    const double yaw = 0.01 * frame;
    v.eye_position = {0.0, 1.6, 0.0};
    v.gaze_direction = {std::sin(yaw), 0.0, -std::cos(yaw)};
    v.angular_speed_dps = 30.0 * (frame % 7);
    v.pixels_per_radian = 500.0;
    return v;
}

// The selector's decision for every object as the allocators' candidates (into `candidates`);
// returns the benches' budget: half-way between every object at its coarsest and at the
// selector's level, in render ms of base + per_triangle * triangles.
inline double decision_candidates(LodSelector& selector, const std::vector<DecisionObject>& objects,
                                  const LodViewer& v, double base_ms, double per_triangle_ms,
                                  std::vector<BudgetCandidate>& candidates) {
    candidates.clear();
    uint64_t wanted = 0, coarsest = 0;
    for (size_t i = 0; i < objects.size(); ++i) {
        const DecisionObject& o = objects[i];
        const LodDecision d = selector.select(i, LodObjectView{o.center, o.radius, o.errors}, v);
        candidates.push_back(BudgetCandidate{
            o.errors, o.triangles, v.pixels_per_radian / (d.distance_m * d.tolerance_px), d.level});
        wanted += o.triangles[size_t(d.level)];
        coarsest += o.triangles.back();
    }
    return base_ms + per_triangle_ms * (double(coarsest) + 0.5 * double(wanted - coarsest));
}

}  // namespace hmdnode::bench
