// Chart segmentation by normal cone: greedy region growing in the manner of the "chart growing"
// step of Sander, Gortler, Snyder & Hoppe, "Signal-specialized parametrization", Eurographics
// Workshop on Rendering 2002, and of Levy et al. 2002 (LSCM, lscm.cpp; section 5 "segmentation"),
// simplified: a seed (the largest unassigned face) grows across edges, breadth first, admitting a
// neighbour while the angle between its normal and the chart's running area-weighted mean normal
// stays below a threshold.
// Cost: O(F log F) time (sorting faces by area; each face enters a queue a bounded number of
// times per adjacent edge), O(V + F) memory.
// Departures: no feature detection and no Lloyd-style re-seeding (the paper's iterative chart
// optimisation); positions are welded only when bit-identical; zero-area faces join whichever
// neighbouring chart reaches them first.
#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>
#include <deque>
#include <numeric>
#include <unordered_map>

#include "hmdnode/bake/uv_atlas.hpp"

namespace hmdnode {

namespace {

struct PosKey {
    uint32_t x, y, z;
    bool operator==(const PosKey& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct PosHash {
    size_t operator()(const PosKey& k) const {
        uint64_t h = k.x * 0x9E3779B97F4A7C15ull;
        h ^= (k.y + 0x7F4A7C15ull + (h << 6) + (h >> 2)) * 0xC2B2AE3D27D4EB4Full;
        h ^= (k.z + 0x165667B19E3779F9ull + (h << 6) + (h >> 2));
        return size_t(h);
    }
};

PosKey key_of(const glm::vec3& p) {
    PosKey k;
    // +0.0 and -0.0 weld: add 0.0f first.
    float x = p.x + 0.0f, y = p.y + 0.0f, z = p.z + 0.0f;
    std::memcpy(&k.x, &x, 4);
    std::memcpy(&k.y, &y, 4);
    std::memcpy(&k.z, &z, 4);
    return k;
}

}  // namespace

// Welded id per vertex: vertices with bit-identical positions share an id.
std::vector<uint32_t> weld_positions(const std::vector<glm::vec3>& positions) {
    std::unordered_map<PosKey, uint32_t, PosHash> map;
    map.reserve(positions.size());
    std::vector<uint32_t> id(positions.size());
    for (size_t i = 0; i < positions.size(); ++i) {
        auto [it, inserted] = map.emplace(key_of(positions[i]), uint32_t(i));
        id[i] = it->second;
        assert(id[i] <= i);  // the lowest index with these bits
    }
    return id;
}

std::vector<int> segment_charts(const std::vector<glm::vec3>& positions,
                                const std::vector<uint32_t>& indices, double angle_deg,
                                size_t max_faces, int* chart_count) {
    const size_t nf = indices.size() / 3;
    assert(indices.size() % 3 == 0 && angle_deg >= 0.0);
    assert(std::all_of(indices.begin(), indices.end(),
                       [&](uint32_t i) { return i < positions.size(); }));
    std::vector<int> chart(nf, -1);
    const std::vector<uint32_t> weld = weld_positions(positions);

    // Face normals (unnormalised: length = 2 area) in double.
    std::vector<glm::dvec3> fn(nf);
    std::vector<double> area(nf);
    for (size_t f = 0; f < nf; ++f) {
        glm::dvec3 a(positions[indices[3 * f]]), b(positions[indices[3 * f + 1]]),
            c(positions[indices[3 * f + 2]]);
        fn[f] = glm::cross(b - a, c - a);
        area[f] = 0.5 * glm::length(fn[f]);
    }

    // Edge adjacency on welded ids: edge key -> faces.
    std::unordered_map<uint64_t, std::vector<uint32_t>> edge_faces;
    edge_faces.reserve(nf * 2);
    auto edge_key = [](uint32_t a, uint32_t b) {
        if (a > b) std::swap(a, b);
        return (uint64_t(a) << 32) | b;
    };
    for (size_t f = 0; f < nf; ++f) {
        for (int e = 0; e < 3; ++e) {
            uint32_t a = weld[indices[3 * f + e]], b = weld[indices[3 * f + (e + 1) % 3]];
            if (a == b) continue;
            edge_faces[edge_key(a, b)].push_back(uint32_t(f));
        }
    }

    std::vector<uint32_t> order(nf);
    std::iota(order.begin(), order.end(), 0u);
    std::stable_sort(order.begin(), order.end(),
                     [&](uint32_t x, uint32_t y) { return area[x] > area[y]; });

    const double cos_limit = std::cos(angle_deg * 3.14159265358979323846 / 180.0);
    int next = 0;
    std::deque<uint32_t> queue;
    for (uint32_t seed : order) {
        if (chart[seed] >= 0) continue;
        const int id = next++;
        chart[seed] = id;
        size_t count = 1;
        glm::dvec3 sum = fn[seed];
        queue.clear();
        queue.push_back(seed);
        while (!queue.empty()) {
            uint32_t f = queue.front();
            queue.pop_front();
            assert(chart[f] == id);  // only faces of the growing chart are queued
            for (int e = 0; e < 3; ++e) {
                uint32_t a = weld[indices[3 * f + e]], b = weld[indices[3 * f + (e + 1) % 3]];
                if (a == b) continue;
                for (uint32_t g : edge_faces[edge_key(a, b)]) {
                    if (chart[g] >= 0) continue;
                    if (max_faces > 0 && count >= max_faces) break;
                    const double len_sum = glm::length(sum), len_g = glm::length(fn[g]);
                    bool ok = true;
                    if (len_g > 0.0 && len_sum > 0.0)
                        ok = glm::dot(sum, fn[g]) >= cos_limit * len_sum * len_g;
                    if (!ok) continue;
                    chart[g] = id;
                    ++count;
                    sum += fn[g];
                    queue.push_back(g);
                }
            }
        }
    }
    // Every face in one chart, ids 0 .. next - 1.
    assert(std::all_of(chart.begin(), chart.end(), [&](int c) { return c >= 0 && c < next; }));
    if (chart_count) *chart_count = next;
    return chart;
}

}  // namespace hmdnode
