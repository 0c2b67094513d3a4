// Progressive meshes (H. Hoppe, "Progressive meshes", SIGGRAPH 1996): a base mesh plus the
// vertex splits that undo, in reverse order, the edge collapses that produced it. Built from any
// edge-collapse algorithm of simplify.hpp; refine() reconstructs the mesh at any triangle count
// between the base and the full mesh, equal (bit for bit) to what simplify() returns for that
// count. File format: docs/simplification.md ("Progressive mesh file").
//
// Ids: positions, wedges (vertices of the output: a position plus its attributes) and faces keep
// the ids of the full mesh (after welding identical vertices), so a split only names what it
// brings back.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scene.hpp"
#include "hmdnode/lod/simplify.hpp"

namespace hmdnode {

struct PmVertex {
    uint32_t id = 0;
    glm::vec3 position{0.0f};
};

// Attributes the primitive lacks stay zero.
struct PmWedge {
    uint32_t id = 0;
    uint32_t position = 0;
    glm::vec3 normal{0.0f};
    glm::vec2 uv0{0.0f};
    glm::vec2 uv1{0.0f};
    glm::vec4 color{0.0f};
};

struct PmFace {
    uint32_t id = 0;
    std::array<uint32_t, 3> wedges{};
};

// Corner 3 * face + k (k = 0, 1, 2) and the wedge it holds on the finer level.
struct PmCorner {
    uint32_t corner = 0;
    uint32_t wedge = 0;
};

// Undoes one edge collapse (the position `removed` had been merged into `kept`).
struct VertexSplit {
    PmVertex removed;
    uint32_t kept = 0;
    glm::vec3 kept_position{0.0f};        // `kept` on the finer level
    std::vector<PmWedge> removed_wedges;  // the wedges of `removed`
    std::vector<PmWedge> kept_wedges;     // wedges of `kept` whose attributes the collapse changed
    std::vector<PmFace> faces;            // faces the split brings back
    std::vector<PmCorner> corners;        // corners that go back to a wedge of `removed`
};

struct ProgressiveMesh {
    bool has_normals = false, has_uv0 = false, has_uv1 = false, has_colors = false;
    int material = -1;
    // Id ranges of the full mesh.
    uint32_t position_count = 0, wedge_count = 0, face_count = 0;
    std::vector<PmVertex> base_positions;
    std::vector<PmWedge> base_wedges;
    std::vector<PmFace> base_faces;
    std::vector<VertexSplit> splits;  // coarse to fine: splits[0] refines the base mesh

    size_t base_triangles() const { return base_faces.size(); }
    size_t full_triangles() const;
};

struct ProgressiveMeshBuild {
    ProgressiveMesh mesh;
    // What simplify() returns for the same targets; the base mesh is the last level.
    std::vector<SimplifiedLevel> levels;
};

// Simplifies `in` with an edge-collapse algorithm (AlgorithmInfo::edge_collapse) down to the last
// target, recording every collapse. Errors: those of simplify(), and an algorithm that is not an
// edge collapse.
Result<ProgressiveMeshBuild> build_progressive_mesh(const Primitive& in, std::string_view algorithm,
                                                    std::span<const size_t> target_triangles,
                                                    const SimplifyOptions& options = {});

// The mesh after applying, in order, as many splits as keep the triangle count <= `triangles`
// (the first level of the collapse sequence at or below that count). Below the base: the base;
// at or above the full count: the full mesh. Vertices are the live wedges in id order, faces the
// live faces in id order, exactly as simplify() orders its output.
Primitive refine(const ProgressiveMesh& pm, size_t triangles);

// The same progressive mesh based at refine(pm, triangles): the splits that keep the count
// <= `triangles` are applied to the base and dropped. refine() of the result gives the same
// primitive as refine() of `pm` for every count from the new base's on. For a mesh recorded past
// the level it is meant to start from (generate_lod_chains' search by error).
ProgressiveMesh rebase_progressive_mesh(const ProgressiveMesh& pm, size_t triangles);

// The binary file (little-endian, docs/simplification.md).
std::vector<uint8_t> encode_progressive_mesh(const ProgressiveMesh& pm);
// Rejects a wrong magic or version, truncation, ids out of range and splits inconsistent with the
// mesh they apply to, with an error naming the byte offset.
Result<ProgressiveMesh> decode_progressive_mesh(std::span<const uint8_t> bytes);
// Atomic write (never a half-written file); read names the file in its errors.
Status write_progressive_mesh(const std::filesystem::path& path, const ProgressiveMesh& pm);
Result<ProgressiveMesh> read_progressive_mesh(const std::filesystem::path& path);

}  // namespace hmdnode
