// The lightmap UV atlas (TEXCOORD_1): chart segmentation by normal cone (uv_charts.cpp),
// per-chart parameterisation by orthogonal projection or least-squares conformal maps (lscm.cpp),
// and packing of every chart of the scene into one or more atlases at a uniform texel density
// (chart_packing.cpp, stb_rect_pack). See docs/baking.md "UV atlas".
//
// Contract of build_uv_atlas() (what the bake relies on):
//  * Which primitives: those for which `options.lightmapped(mesh, primitive)` is true (default:
//    every primitive). A chosen primitive that already has uv1 keeps it untouched (and keeps its
//    material's lightmap if it has one; if its material has none, the primitive is listed in
//    AtlasReport::kept_without_lightmap and gets nothing). Every other chosen primitive gets uv1.
//  * uv1 is in glTF convention: uv (0,0) = top-left corner of the lightmap texture, texel (x, y)
//    covers uv [x/W, (x+1)/W] x [y/H, (y+1)/H]. Each chart's bounding-box corner lies on a texel
//    corner (integer texel origin).
//  * Instances: with unshare_instances (default), a mesh placed by several nodes is first copied
//    once per extra node, so every instance has its own texels.
//  * Density: a chart's uv area equals its surface area in world metres^2 (mesh space x the largest
//    axis scale among the nodes using the mesh; 1 for meshes no node uses) times
//    texels_per_metre^2, so one texel covers about 1/texels_per_metre metres everywhere.
//  * Padding: between the texels any two charts touch (conservatively: every texel their uv
//    rectangle overlaps) lie at least `padding_texels` empty texels; each chart also keeps
//    padding_texels / 2 texels from the atlas border. The bake's dilation fills that gutter.
//  * Vertices on chart boundaries are duplicated (one copy per chart, all other attributes copied);
//    indices are remapped; winding is unchanged. All charts of one primitive go to one atlas when
//    they fit; otherwise the primitive is split into one primitive per atlas (appended to the
//    mesh's primitive list, same attributes, material cloned per atlas).
//  * Textures: one new RGBA8 texture per atlas (name "lightmap_<k>", width x height set, pixels
//    zero with alpha 255), filled later by the bake. Every chosen primitive's material gets
//    MOZ_lightmap {texture of its atlas, tex_coord 1, intensity 1}; a material shared by
//    primitives placed in different atlases (or already pointing at another lightmap) is cloned
//    per atlas; a primitive with no material gets a new white material per atlas.
//  * Errors (Result error; the scene is left unchanged, the work is done on a copy): options out
//    of range; non-finite positions (names mesh/primitive/vertex); a chart larger than
//    max_atlas_size at the requested density (names the mesh, the chart's size in texels, and the
//    largest density that would fit).
// Cost: O(F log F) for segmentation, a sparse Cholesky per curved chart, O(C log C) packing per
// atlas attempt; memory O(V + F).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scene.hpp"

namespace hmdnode {

struct AtlasOptions {
    double texels_per_metre = 32.0;  // > 0
    int padding_texels = 2;          // >= 2
    int max_atlas_size = 1024;       // width and height limit of one atlas, >= 16
    double chart_angle_deg = 60.0;   // a face joins a chart while its normal is within this of
                                     // the chart's average normal
    double planar_angle_deg = 10.0;  // all normals within this of the average: orthogonal
                                     // projection; otherwise LSCM
    size_t max_chart_faces = 0;      // 0: unlimited
    // A mesh placed by several nodes is copied for every node after the first (appended to
    // scene.meshes, named "<name>_instance<k>", node.mesh updated) so each instance gets its own
    // texels; false: instances share the first one's charts (and its light).
    bool unshare_instances = true;
    // Which primitives get a lightmap; empty = all. Copies made by unshare_instances are asked
    // with the index of the mesh they copy.
    std::function<bool(int mesh, int primitive)> lightmapped;
};

struct AtlasReport {
    size_t charts = 0;
    size_t atlases = 0;
    size_t planar_charts = 0;       // parameterised by projection
    size_t lscm_charts = 0;         // parameterised by LSCM
    size_t split_charts = 0;        // charts cut because their map flipped or overlapped
    size_t primitives = 0;          // primitives given uv1
    size_t kept_primitives = 0;     // chosen primitives that already had uv1
    size_t unshared_instances = 0;  // meshes copied by unshare_instances
    std::vector<std::string> kept_without_lightmap;  // "mesh/primitive" kept with no lightmap
    size_t vertices_before = 0, vertices_after = 0;  // of the primitives given uv1
    std::vector<int> textures;                       // the atlas textures created, one per atlas
    std::vector<int> widths, heights;
    size_t atlas_texels = 0;    // sum of width x height
    double chart_texels = 0.0;  // sum of the charts' uv areas in texels (= surface area x
                                // texels_per_metre^2)
    double utilisation = 0.0;   // chart_texels / atlas_texels, in [0, 1]
    double mean_conformal_distortion = 1.0;  // area-weighted mean of sigma_max / sigma_min
    double max_area_distortion = 1.0;        // max over charts of ParamQuality's, >= 1
};

Result<AtlasReport> build_uv_atlas(Scene& scene, const AtlasOptions& options);

// ---- building blocks (exposed for tests and for the bake's diagnostics) ----------------------

// Welded id per vertex: the lowest index among vertices with bit-identical positions (+0 = -0).
std::vector<uint32_t> weld_positions(const std::vector<glm::vec3>& positions);

// Chart segmentation of one triangle list by normal cone. Vertices with bit-identical positions
// are welded for adjacency. Seed = largest unassigned face; a neighbour across an edge joins
// while the angle between its normal and the chart's area-weighted mean normal is below
// angle_deg (zero-area faces join any neighbour) and the chart has fewer than max_faces faces
// (0: unlimited). Returns the chart id of every face, ids 0..count-1, each chart edge-connected.
std::vector<int> segment_charts(const std::vector<glm::vec3>& positions,
                                const std::vector<uint32_t>& indices, double angle_deg,
                                size_t max_faces, int* chart_count);

// A chart as its own small mesh: local vertices and triangles.
struct ChartMesh {
    std::vector<glm::dvec3> positions;
    std::vector<uint32_t> indices;
};

// Least-squares conformal map (Levy et al. 2002) of a connected chart, pinning two far-apart
// vertices; returns uv per chart vertex, scaled so that the uv area equals the 3D area. Error
// when the system is singular or the result is not finite.
Result<std::vector<glm::dvec2>> lscm_parameterise(const ChartMesh& chart);

// Orthogonal projection onto the plane through the area-weighted mean normal (no scaling).
std::vector<glm::dvec2> planar_parameterise(const ChartMesh& chart);

// Quality of a parameterisation, from the Jacobian of the 3D->uv map on each triangle.
struct ParamQuality {
    double mean_conformal = 1.0;  // area-weighted mean of sigma_max / sigma_min (1 = conformal)
    double max_conformal = 1.0;
    double area_ratio = 1.0;           // total uv area / total 3D area
    double max_stretch = 1.0;          // max over triangles of sigma_max / sqrt(area_ratio)
    double min_stretch = 1.0;          // min over triangles of sigma_min / sqrt(area_ratio)
    double max_area_distortion = 1.0;  // max over triangles of max(r, 1/r), r = the triangle's
                                       // uv/3D area ratio divided by area_ratio
    size_t flipped = 0;                // triangles whose uv orientation differs from the majority
    size_t degenerate = 0;             // triangles of zero 3D area (skipped)
    size_t overlapping = 0;  // triangles whose uv centroid lies strictly inside another triangle
                             // of the chart (a global fold or overlap; 0 when injective)
};
ParamQuality measure_parameterisation(const ChartMesh& chart, const std::vector<glm::dvec2>& uv);

}  // namespace hmdnode
