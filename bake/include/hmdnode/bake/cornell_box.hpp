// The Cornell box from its published geometry
// (https://www.graphics.cornell.edu/online/box/data.html), converted from millimetres to metres, as
// a Scene for the baker and the renderer.
//
// Surfaces: floor, ceiling, back wall (white), left wall x ~ 0.55 m (red), right wall x = 0
// (green), the short and the tall block (white), and the light: the quad x 0.213..0.343 m,
// z 0.227..0.332 m at y 0.5487 m (0.1 mm under the ceiling, so the two are not coplanar), facing
// down, emissive. The front (z = 0) is open. Faces point into the room (walls) or out of the
// blocks. Reflectances are RGB approximations of the measured spectra (the averages of the
// published 400-700 nm curves over rough R, G, B bands): white (0.73, 0.72, 0.68), red
// (0.63, 0.065, 0.05), green (0.15, 0.45, 0.09); light albedo 0.78, emitted radiance
// (17, 12, 4) (a common RGB stand-in for the measured spectrum, as in PBRT's scene).
//
// Camera of the published data: at (0.278, 0.273, -0.800) m looking along +z, up +y, square
// image, vertical field of view 2 atan(12.5 / 35) = 39.3 degrees.
#pragma once

#include <glm/glm.hpp>

#include "hmdnode/core/scene.hpp"

namespace hmdnode {

struct CornellCamera {
    glm::vec3 position{0.278f, 0.273f, -0.800f};
    glm::vec3 forward{0.0f, 0.0f, 1.0f};
    glm::vec3 up{0.0f, 1.0f, 0.0f};
    float vertical_fov_rad = 0.68597f;  // 2 atan(12.5 / 35)
};

// texels_per_metre > 0: every surface but the light gets a planar chart in one lightmap
// (TEXCOORD_1, MOZ_lightmap texture 0, charts shelf-packed with 3 texels of padding); the light
// quad has no lightmap. Otherwise geometry and materials only. Material indices: 0 white, 1 red,
// 2 green, 3 light.
Scene cornell_box_scene(double texels_per_metre);

}  // namespace hmdnode
