// Texel rasterisation in lightmap (uv1) space: for every texel of every lightmap texture the
// surface points it covers, with world position, normal and albedo (docs/baking.md).
//
// Coverage is conservative: a texel touched by a triangle (2-D separating-axis test of the texel
// square against the triangle) is covered even when its centre lies outside. Each covered texel
// gets the points of an n x n stratified grid (jitter-free: stratum centres) that fall inside each
// triangle touching it; a touched texel with no grid point inside a triangle gets that triangle's
// point closest to the texel centre. A texel shared by several triangles holds the samples of each.
//
// Threads: runs on the calling thread; O(sum over triangles of covered texels x n^2).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scene.hpp"

namespace hmdnode {

struct TexelSample {
    glm::vec3 position{0.0f};  // world
    glm::vec3 normal{0.0f};    // world, unit (interpolated vertex normal, else face normal)
    glm::vec3 face_normal{0.0f};
    glm::vec3 albedo{1.0f};  // base colour factor (texture not applied here)
    float weight = 1.0f;     // share of the texel's area this sample stands for (sums ~1)
};

struct TexelRaster {
    int texture = -1;  // the lightmap texture
    int width = 0, height = 0;
    // CSR: samples of texel i are samples[first[i] .. first[i + 1]).
    std::vector<uint32_t> first;
    std::vector<TexelSample> samples;
    std::vector<float> texel_size_m;  // world edge length of the texel (0 where uncovered)
    size_t covered = 0;

    bool is_covered(size_t texel) const { return first[texel + 1] > first[texel]; }
};

// Every lightmap texture used by a primitive that has uv1 (each mesh once, every LOD level).
// `strata` n >= 1 gives n x n candidate points per texel. Errors: a lightmap texture out of
// range or without a size; a lightmapped primitive without TEXCOORD_1 (mesh, primitive named).
Result<std::vector<TexelRaster>> rasterize_texels(const Scene& scene, int strata);

}  // namespace hmdnode
