// Direct-light baking into lightmaps (MOZ_lightmap + TEXCOORD_1) and vertex colours (COLOR_0):
// the first, direct-light-only baker, kept beside the path tracer (path_tracer.hpp, Embree) that
// `hmdnode bake` uses for global illumination.
//
// Irradiance at a point p with unit normal n:
//   E = sum over lights of  I * colour * max(0, n.l) * att / r^2 * V  +  pi * L_ambient
// with I the light's intensity (candela), l the unit vector to the light, r its distance, att the
// KHR_lights_punctual range window max(0, min(1, 1 - (r / range)^4)) (1 when range is 0) times the
// spot cone factor, V = 0 when a shadow ray hits any triangle of the scene, else 1. Directional
// lights give I * colour * max(0, n.l) * V (lux). The ambient term is a constant irradiance from a
// uniform environment of radiance L_ambient without occlusion: a crude stand-in for indirect light.
//
// Geometry: every object of flatten_objects() at its level 0, in world space, casts shadows (LOD
// alternates do not, or coarse levels would shadow the fine one).
//
// Threads: all functions run on the calling thread; DirectLighting is immutable once built and
// its queries may be called from several threads.
#pragma once

#include <cstddef>
#include <vector>

#include <glm/glm.hpp>

#include "hmdnode/bake/bvh.hpp"
#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scene.hpp"

namespace hmdnode {

struct DirectBakeOptions {
    glm::vec3 ambient_radiance{0.0f};  // L_ambient: every point gets E += pi * L_ambient
    bool shadows = true;
    float normal_offset_m = 1e-3f;  // shadow rays start this far along the normal (world metres)
    int dilation_texels = 2;        // lightmap gutter filled around each chart, >= 0
    int texel_samples = 1;          // n: n x n stratified samples per lightmap texel (1: centre),
                                    // averaging E over the texel to antialias shadow edges
};

// A light in world space, ready for evaluation.
struct WorldLight {
    Light::Type type = Light::Type::Point;
    glm::vec3 position{0.0f};
    glm::vec3 direction{0.0f, 0.0f, -1.0f};  // where it shines (spot, directional), unit
    glm::vec3 intensity_rgb{0.0f};           // intensity * colour
    float range = 0.0f;
    float cone_scale = 0.0f, cone_offset = 1.0f;  // spot: clamp(cos * scale + offset, 0, 1)^2
};

// World transform of every node (parents from the children lists; roots and orphans at identity).
std::vector<glm::dmat4> node_world_matrices(const Scene& scene);

// Every KHR_lights_punctual light of the scene in world space: placed by its node (at the origin
// looking down -Z when it has none), intensity times colour, spot cone as clamp(cos * scale +
// offset). The one conversion both bakers use.
std::vector<WorldLight> world_lights(const Scene& scene);

// The lights and the shadow-casting triangles of a scene, evaluated at world points.
class DirectLighting {
  public:
    DirectLighting(const Scene& scene, const DirectBakeOptions& options);

    // E (rgb) at world point p with unit normal n. Shadow rays start at p + n * normal_offset_m and
    // ignore hits closer than skip_m (a coarse LOD level's surface lies within its geometric error
    // of the occluding level 0).
    glm::vec3 irradiance(const glm::vec3& p, const glm::vec3& n, float skip_m = 0.0f) const;

    const std::vector<WorldLight>& lights() const { return lights_; }
    const TriangleBvh& occluders() const { return bvh_; }

  private:
    DirectBakeOptions options_;
    std::vector<WorldLight> lights_;
    TriangleBvh bvh_;
};

// One baked lightmap texture.
struct LightmapBake {
    int texture = -1;
    int width = 0, height = 0;
    float intensity = 1.0f;     // max E over the map (1 when all dark): texel * intensity = E
    size_t covered_texels = 0;  // texel centres inside some triangle
    size_t dilated_texels = 0;  // gutter texels filled by dilation
    std::vector<glm::vec3> irradiance;  // float E per texel, rows top to bottom; 0 where empty
};

// Lightmap mode. For every primitive (of every level of every object) whose material has a
// lightmap texture and which has uv1: rasterises its triangles at texel centres in uv1 space
// (uv (0,0) = top-left of the texture), evaluates E at the interpolated world position and normal
// (the face normal when the primitive has no normals) -- with texel_samples > 1, the mean of E at
// n x n points of the texel, clamped onto the triangle that owns the texel centre -- dilates
// `dilation_texels` rings into empty texels (mean of filled 8-neighbours), and stores RGBA8 = E /
// intensity (alpha 255) in the texture, whose width and height the caller has set. Writes
// `intensity` to every material using the texture. Where triangles overlap in uv1, the first one
// rasterised keeps the texel. Errors: a lightmap texture index out of range or of zero size; a
// lightmapped primitive without uv1.
Result<std::vector<LightmapBake>> bake_lightmaps(Scene& scene, const DirectLighting& lighting,
                                                 const DirectBakeOptions& options);

// Vertex mode. For every primitive (of every level of every object) whose material has no
// lightmap (or which has no uv1): COLOR_0 = (E / pi, 1) at each vertex, so albedo * COLOR_0 is
// the outgoing radiance of a Lambertian surface. Normals are the primitive's (area-weighted face
// normals when it has none). Levels other than 0 skip shadow hits within twice their geometric
// error. A mesh used by several objects is baked for the first. Returns the number of vertices.
size_t bake_vertex_colors(Scene& scene, const DirectLighting& lighting);

}  // namespace hmdnode
