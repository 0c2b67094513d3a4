// Private to hal: a pose in a Vive/Index configuration written as [qx, qy, qz, qw, x, y, z] (a Vive
// HMD's trackref_from_head and trackref_from_imu), read by lighthouse_config.cpp (the head frame
// of the sensor model) and survive_recording.cpp (the IMU's factory calibration).
#pragma once

#include <cmath>
#include <string>
#include <utility>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>
#include <nlohmann/json.hpp>

#include "hmdnode/core/result.hpp"

namespace hmdnode::detail {

// The rotation (its unit quaternion) and the origin; `what` names the field in the error.
inline Result<std::pair<glm::dmat3, glm::dvec3>> config_pose7(const nlohmann::json& a,
                                                              const std::string& what) {
    bool ok = a.is_array() && a.size() == 7;
    double v[7] = {};
    for (size_t i = 0; ok && i < 7; ++i) {
        ok = a[i].is_number() && std::isfinite(a[i].get<double>());
        if (ok) v[i] = a[i].get<double>();
    }
    const glm::dquat q(v[3], v[0], v[1], v[2]);
    if (!ok || std::abs(glm::length(q) - 1) > 0.01)
        return make_error(what + ": not [qx, qy, qz, qw, x, y, z] with a unit quaternion");
    return std::pair{glm::mat3_cast(glm::normalize(q)), glm::dvec3(v[4], v[5], v[6])};
}

}  // namespace hmdnode::detail
