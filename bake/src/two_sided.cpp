// Two-sided surfaces baked per side: a primitive of a double-sided material becomes two sheets,
// the front as it was and a back copy with the winding reversed and the normals negated, and its
// material becomes single-sided (cloned as `<name>_one_sided` when primitives that are not split
// share it). Each sheet then gets its own texels from the UV atlas (or its own vertex light), the
// path tracer, built before the split from the double-sided original, lights each sheet from its
// own side, and any renderer picks the side by back-face culling (glTF: a single-sided material's
// back faces are not drawn). What Unity and Bakery call "double-sided GI" done as geometry.
// Cost: O(vertices + indices) per split primitive; it doubles their triangles in the output.
#include <algorithm>
#include <cassert>
#include <string>
#include <vector>

#include "lightmap_passes.hpp"

namespace hmdnode::detail {

size_t split_two_sided(Scene& scene, const std::function<bool(const Primitive&)>& keep) {
    assert(keep);
    std::vector<int> split_users(scene.materials.size(), 0), kept_users(scene.materials.size(), 0);
    auto double_sided = [&](const Primitive& p) {
        return p.material >= 0 && size_t(p.material) < scene.materials.size() &&
               scene.materials[size_t(p.material)].double_sided && !p.indices.empty();
    };
    for (const Mesh& mesh : scene.meshes)
        for (const Primitive& p : mesh.primitives)
            if (double_sided(p)) ++(keep(p) ? kept_users : split_users)[size_t(p.material)];
    // The single-sided material for the split primitives of each double-sided material.
    std::vector<int> one_sided(scene.materials.size(), -1);
    const size_t material_count = scene.materials.size();
    for (size_t m = 0; m < material_count; ++m) {
        if (split_users[m] == 0) continue;
        if (kept_users[m] == 0) {
            scene.materials[m].double_sided = false;
            one_sided[m] = int(m);
        } else {
            Material clone = scene.materials[m];
            clone.name += "_one_sided";
            clone.double_sided = false;
            scene.materials.push_back(clone);
            one_sided[m] = int(scene.materials.size() - 1);
        }
    }
    size_t split = 0;
    for (Mesh& mesh : scene.meshes)
        for (Primitive& p : mesh.primitives) {
            if (p.material < 0 || size_t(p.material) >= material_count ||
                one_sided[size_t(p.material)] < 0 || p.indices.empty() || keep(p))
                continue;
            const uint32_t n = uint32_t(p.positions.size());
            auto twice = [](auto& v) {
                // note: not insert(end, begin, end): a range into the vector itself is undefined.
                const size_t n = v.size();
                v.resize(2 * n);
                std::copy_n(v.begin(), n, v.begin() + std::ptrdiff_t(n));
            };
            twice(p.positions);
            twice(p.uv0);
            twice(p.uv1);
            twice(p.colors);
            twice(p.light);
            if (!p.normals.empty()) {  // without normals the reversed winding flips the face's
                p.normals.reserve(2 * size_t(n));
                for (uint32_t v = 0; v < n; ++v) p.normals.push_back(-p.normals[v]);
            }
            const size_t faces = p.indices.size();
            for (size_t t = 0; t < faces; t += 3)  // reversed winding: the back side faces front
                p.indices.insert(p.indices.end(),
                                 {p.indices[t] + n, p.indices[t + 2] + n, p.indices[t + 1] + n});
            // Two sheets: every attribute twice, the back sheet's triangles on the copies.
            assert(p.positions.size() == 2 * size_t(n) && p.indices.size() == 2 * faces);
            assert(p.normals.empty() || p.normals.size() == p.positions.size());
            p.material = one_sided[size_t(p.material)];
            assert(p.material >= 0 && size_t(p.material) < scene.materials.size() &&
                   !scene.materials[size_t(p.material)].double_sided);
            ++split;
        }
    return split;
}

}  // namespace hmdnode::detail
