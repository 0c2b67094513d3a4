// Headset profiles: the profile JSON format (load, save, validate), the import of an
// OpenVR/lighthouse device config ("tracking_to_eye_transform", as libsurvive records it and
// Monado reads it in src/xrt/drivers/vive/vive_config.c, _get_distortion_properties and
// _calculate_fov), and the built-in "generic" profile. Format: docs/lens-distortion.md.
//
// Source: Valve's lighthouse HMD JSON documentation (fields of tracking_to_eye_transform and
// device), Monado vive_config.c (which fields it reads, and its FOV from intrinsics / (1 + grow)).
//
// Cost: linear in the JSON text; no state.
#include <cmath>
#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/render/lens.hpp"

namespace hmdnode {
namespace {

using nlohmann::json;

const char* const kChannelNames[3] = {"red", "green", "blue"};

// Reads typed members and records the first error, naming the source and the field path.
struct Reader {
    std::string source;
    std::string error;

    bool ok() const { return error.empty(); }
    void fail(const std::string& path, const std::string& what) {
        if (error.empty()) error = source + ": " + path + ": " + what;
    }
    const json* member(const json& obj, const std::string& path, const char* key,
                       bool required = true) {
        if (!ok()) return nullptr;
        if (!obj.is_object()) {
            fail(path, "expected an object");
            return nullptr;
        }
        auto it = obj.find(key);
        if (it == obj.end()) {
            if (required) fail(join(path, key), "missing");
            return nullptr;
        }
        return &*it;
    }
    static std::string join(const std::string& path, const char* key) {
        return path.empty() ? std::string(key) : path + "." + key;
    }
    void only_keys(const json& obj, const std::string& path, const std::set<std::string>& keys) {
        if (!ok() || !obj.is_object()) return;
        for (const auto& item : obj.items())
            if (!keys.count(item.key())) fail(join(path, item.key().c_str()), "unknown field");
    }
    double number(const json& j, const std::string& path) {
        if (!ok()) return 0.0;
        if (!j.is_number()) {
            fail(path, "expected a number");
            return 0.0;
        }
        const double v = j.get<double>();
        if (!std::isfinite(v)) fail(path, "not a finite number");
        return v;
    }
    double number(const json& obj, const std::string& path, const char* key, double fallback,
                  bool required) {
        const json* j = member(obj, path, key, required);
        return j ? number(*j, join(path, key)) : fallback;
    }
    int integer(const json& obj, const std::string& path, const char* key) {
        const json* j = member(obj, path, key);
        if (!j) return 0;
        if (!j->is_number_integer()) {
            fail(join(path, key), "expected an integer");
            return 0;
        }
        return j->get<int>();
    }
    std::string string(const json& obj, const std::string& path, const char* key,
                       bool required = true) {
        const json* j = member(obj, path, key, required);
        if (!j) return {};
        if (!j->is_string()) {
            fail(join(path, key), "expected a string");
            return {};
        }
        return j->get<std::string>();
    }
    // An array of n numbers (or, with at_least, at least n: the first max_n are kept).
    std::vector<double> numbers(const json& j, const std::string& path, size_t n,
                                bool at_least = false, size_t max_n = 0) {
        if (!ok()) return std::vector<double>(n, 0.0);
        const std::string expect =
            "expected " + std::string(at_least ? "at least " : "") + std::to_string(n) + " numbers";
        if (!j.is_array() || j.size() < n || (!at_least && j.size() != n)) {
            fail(path, expect);
            return std::vector<double>(n, 0.0);
        }
        std::vector<double> out;
        for (size_t i = 0; i < j.size() && i < std::max(n, max_n); ++i)
            out.push_back(number(j[i], path + "[" + std::to_string(i) + "]"));
        return out;
    }
    // A 3x3 matrix as three rows of three numbers.
    glm::dmat3 matrix_rows(const json& j, const std::string& path) {
        glm::dmat3 m(1.0);
        if (!ok()) return m;
        if (!j.is_array() || j.size() != 3) {
            fail(path, "expected 3 rows of 3 numbers");
            return m;
        }
        for (int r = 0; r < 3; ++r) {
            const std::vector<double> row = numbers(j[r], path + "[" + std::to_string(r) + "]", 3);
            for (int c = 0; c < 3 && ok(); ++c) m[c][r] = row[c];
        }
        return m;
    }
};

bool finite(const glm::dmat3& m) {
    for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r)
            if (!std::isfinite(m[c][r])) return false;
    return true;
}

bool fov_equal(const EyeFov& a, const EyeFov& b) {
    return a.tan_left == b.tan_left && a.tan_right == b.tan_right && a.tan_up == b.tan_up &&
           a.tan_down == b.tan_down;
}

// Puts each array of plain numbers on one line ("[1.0, 0.0, 0.0]") in nlohmann's indented dump.
std::string collapse_number_arrays(const std::string& text) {
    std::string out;
    out.reserve(text.size());
    for (size_t i = 0; i < text.size(); ++i) {
        if (text[i] == '[') {
            const size_t close = text.find(']', i);
            const size_t nested = text.find_first_of("[{\"", i + 1);
            if (close != std::string::npos && (nested == std::string::npos || nested > close)) {
                std::string items;
                for (size_t k = i + 1; k < close; ++k) {
                    const char c = text[k];
                    if (c == ' ' || c == '\n') continue;
                    items += c;
                    if (c == ',') items += ' ';
                }
                out += "[" + items + "]";
                i = close;
                continue;
            }
        }
        out += text[i];
    }
    return out;
}

// Monado's render FOV of a vive eye (vive_config.c, _calculate_fov): the intrinsics divided by
// (1 + grow_for_undistort) describe the render target in NDC; in tangents
//   left = -(1 - cx')/fx', right = (1 + cx')/fx', up = (1 + cy')/fy', down = -(1 - cy')/fy'.
EyeFov monado_render_fov(const EyeLens& lens) {
    const double s = 1.0 + lens.grow_for_undistort;
    const double fx = lens.intrinsics[0][0] / s, fy = lens.intrinsics[1][1] / s;
    const double cx = lens.intrinsics[2][0] / s, cy = lens.intrinsics[2][1] / s;
    return EyeFov{-(1.0 - cx) / fx, (1.0 + cx) / fx, (1.0 + cy) / fy, -(1.0 - cy) / fy};
}

LensModel parse_model(Reader& rd, const json& eye, const std::string& path) {
    const std::string name = rd.string(eye, path, "model");
    if (!rd.ok()) return LensModel::none;
    for (LensModel m : {LensModel::none, LensModel::poly_radial, LensModel::vive_dpoly3_scaled})
        if (name == lens_model_name(m)) return m;
    rd.fail(path + ".model",
            "unknown model \"" + name + "\" (expected none, poly_radial or vive_dpoly3_scaled)");
    return LensModel::none;
}

EyeLens parse_eye(Reader& rd, const json& j, const std::string& path) {
    EyeLens lens;
    rd.only_keys(j, path,
                 {"model", "channel", "intrinsics", "grow_for_undistort", "undistort_r2_cutoff",
                  "aspect_x_over_y", "eye_to_head", "fov"});
    lens.model = parse_model(rd, j, path);
    if (const json* ch = rd.member(j, path, "channel", lens.model != LensModel::none)) {
        const std::string chpath = path + ".channel";
        rd.only_keys(*ch, chpath, {"red", "green", "blue"});
        for (int i = 0; i < 3; ++i) {
            const json* c = rd.member(*ch, chpath, kChannelNames[i]);
            if (!c) break;
            const std::string cpath = chpath + "." + kChannelNames[i];
            rd.only_keys(*c, cpath, {"center", "coeffs"});
            if (const json* center = rd.member(*c, cpath, "center")) {
                const std::vector<double> v = rd.numbers(*center, cpath + ".center", 2);
                lens.channel[i].center = glm::dvec2(v[0], v[1]);
            }
            if (const json* coeffs = rd.member(*c, cpath, "coeffs")) {
                const std::vector<double> v = rd.numbers(*coeffs, cpath + ".coeffs", 4);
                for (int k = 0; k < 4; ++k) lens.channel[i].coeffs[k] = v[k];
            }
        }
    }
    const bool vive = lens.model == LensModel::vive_dpoly3_scaled;
    if (const json* k = rd.member(j, path, "intrinsics", vive))
        lens.intrinsics = rd.matrix_rows(*k, path + ".intrinsics");
    lens.grow_for_undistort = rd.number(j, path, "grow_for_undistort", 0.0, false);
    lens.undistort_r2_cutoff = rd.number(j, path, "undistort_r2_cutoff", 0.0, false);
    lens.aspect_x_over_y = rd.number(j, path, "aspect_x_over_y", 0.0, false);
    if (const json* e = rd.member(j, path, "eye_to_head", false))
        lens.eye_to_head = rd.matrix_rows(*e, path + ".eye_to_head");
    if (const json* f = rd.member(j, path, "fov", !vive)) {
        const std::string fpath = path + ".fov";
        rd.only_keys(*f, fpath, {"tan_left", "tan_right", "tan_up", "tan_down"});
        lens.fov.tan_left = rd.number(*f, fpath, "tan_left", 0.0, true);
        lens.fov.tan_right = rd.number(*f, fpath, "tan_right", 0.0, true);
        lens.fov.tan_up = rd.number(*f, fpath, "tan_up", 0.0, true);
        lens.fov.tan_down = rd.number(*f, fpath, "tan_down", 0.0, true);
    }
    return lens;
}

Result<json> parse_json(const std::string& text, const std::string& source) {
    try {
        return json::parse(text);
    } catch (const json::parse_error& e) {
        return make_error(source + ": not valid JSON at byte " + std::to_string(e.byte) + ": " +
                          e.what());
    } catch (const json::exception& e) {  // e.g. out_of_range.406: a number overflows a double
        return make_error(source + ": not valid JSON: " + e.what());
    }
}

}  // namespace

const char* lens_model_name(LensModel model) {
    switch (model) {
        case LensModel::none:
            return "none";
        case LensModel::poly_radial:
            return "poly_radial";
        case LensModel::vive_dpoly3_scaled:
            return "vive_dpoly3_scaled";
    }
    return "none";
}

bool operator==(const LensChannel& a, const LensChannel& b) {
    return a.center == b.center && a.coeffs == b.coeffs;
}

bool operator==(const EyeLens& a, const EyeLens& b) {
    return a.model == b.model && a.channel[0] == b.channel[0] && a.channel[1] == b.channel[1] &&
           a.channel[2] == b.channel[2] && a.intrinsics == b.intrinsics &&
           a.grow_for_undistort == b.grow_for_undistort &&
           a.undistort_r2_cutoff == b.undistort_r2_cutoff &&
           a.aspect_x_over_y == b.aspect_x_over_y && a.eye_to_head == b.eye_to_head &&
           fov_equal(a.fov, b.fov);
}

bool operator==(const HeadsetProfile& a, const HeadsetProfile& b) {
    return a.name == b.name && a.panel_width == b.panel_width && a.panel_height == b.panel_height &&
           a.refresh_hz == b.refresh_hz && a.eye[0] == b.eye[0] && a.eye[1] == b.eye[1];
}

Status validate_headset_profile(const HeadsetProfile& p, const std::string& source) {
    auto fail = [&](const std::string& path, const std::string& what) -> Status {
        return make_error(source + ": " + path + ": " + what);
    };
    if (p.panel_width <= 0) return fail("panel_width", "must be positive");
    if (p.panel_height <= 0) return fail("panel_height", "must be positive");
    if (!(std::isfinite(p.refresh_hz) && p.refresh_hz > 0.0))
        return fail("refresh_hz", "must be a positive finite number");
    for (int e = 0; e < 2; ++e) {
        const EyeLens& lens = p.eye[e];
        const std::string path = "eye[" + std::to_string(e) + "]";
        for (int i = 0; i < 3; ++i) {
            const LensChannel& ch = lens.channel[i];
            const std::string cpath = path + ".channel." + kChannelNames[i];
            if (!std::isfinite(ch.center.x) || !std::isfinite(ch.center.y))
                return fail(cpath + ".center", "not finite");
            for (double k : ch.coeffs)
                if (!std::isfinite(k)) return fail(cpath + ".coeffs", "not finite");
            if (lens.model == LensModel::poly_radial && !(ch.coeffs[0] > 0.0))
                return fail(cpath + ".coeffs", "k0 must be positive (the scale at the centre)");
            if (lens.model == LensModel::vive_dpoly3_scaled && !(1.0 + ch.coeffs[3] > 0.0))
                return fail(cpath + ".coeffs", "1 + k4 must be positive (the scale at the centre)");
        }
        if (!finite(lens.intrinsics)) return fail(path + ".intrinsics", "not finite");
        if (lens.model == LensModel::vive_dpoly3_scaled) {
            if (std::abs(glm::determinant(lens.intrinsics)) < 1e-12)
                return fail(path + ".intrinsics", "not invertible");
            const glm::dvec3 axis = glm::inverse(lens.intrinsics) * glm::dvec3(0.0, 0.0, 1.0);
            if (!(axis.z < 0.0))
                return fail(path + ".intrinsics", "does not look forward (-z) at the centre");
        }
        if (!(std::isfinite(lens.grow_for_undistort) && lens.grow_for_undistort > -1.0))
            return fail(path + ".grow_for_undistort", "must be finite and > -1");
        if (!(std::isfinite(lens.undistort_r2_cutoff) && lens.undistort_r2_cutoff >= 0.0))
            return fail(path + ".undistort_r2_cutoff", "must be finite and >= 0");
        if (!(std::isfinite(lens.aspect_x_over_y) && lens.aspect_x_over_y >= 0.0))
            return fail(path + ".aspect_x_over_y", "must be finite and >= 0");
        if (!finite(lens.eye_to_head)) return fail(path + ".eye_to_head", "not finite");
        const glm::dmat3 rtr = glm::transpose(lens.eye_to_head) * lens.eye_to_head;
        for (int c = 0; c < 3; ++c)
            for (int r = 0; r < 3; ++r)
                if (std::abs(rtr[c][r] - (c == r ? 1.0 : 0.0)) > 1e-5)
                    return fail(path + ".eye_to_head", "not a rotation (columns not orthonormal)");
        if (glm::determinant(lens.eye_to_head) < 0.0)
            return fail(path + ".eye_to_head", "not a rotation (a reflection)");
        const EyeFov& f = lens.fov;
        if (!std::isfinite(f.tan_left) || !std::isfinite(f.tan_right) || !std::isfinite(f.tan_up) ||
            !std::isfinite(f.tan_down))
            return fail(path + ".fov", "not finite");
        if (lens.model != LensModel::vive_dpoly3_scaled &&
            !(f.tan_left < f.tan_right && f.tan_down < f.tan_up))
            return fail(path + ".fov", "empty (needs tan_left < tan_right, tan_down < tan_up)");
    }
    return {};
}

Result<HeadsetProfile> parse_headset_profile(const std::string& text, const std::string& source) {
    Result<json> parsed = parse_json(text, source);
    if (!parsed.ok()) return parsed.error();
    const json& j = *parsed;
    Reader rd{source, ""};
    HeadsetProfile p;
    rd.only_keys(j, "", {"version", "name", "panel_width", "panel_height", "refresh_hz", "eye"});
    if (const json* v = rd.member(j, "", "version")) {
        if (!v->is_number_integer() || v->get<int64_t>() != 1) rd.fail("version", "expected 1");
    }
    p.name = rd.string(j, "", "name");
    p.panel_width = rd.integer(j, "", "panel_width");
    p.panel_height = rd.integer(j, "", "panel_height");
    p.refresh_hz = rd.number(j, "", "refresh_hz", 90.0, true);
    if (const json* eyes = rd.member(j, "", "eye")) {
        if (!eyes->is_array()) {
            rd.fail("eye", "expected an array of 2 eyes");
        } else if (eyes->size() != 2) {
            rd.fail("eye", "expected 2 eyes, got " + std::to_string(eyes->size()));
        } else {
            for (int e = 0; e < 2; ++e)
                p.eye[e] = parse_eye(rd, (*eyes)[e], "eye[" + std::to_string(e) + "]");
        }
    }
    if (!rd.ok()) return make_error(rd.error);
    if (Status s = validate_headset_profile(p, source); !s.ok()) return s.error();
    return p;
}

Result<HeadsetProfile> load_headset_profile(const std::filesystem::path& path) {
    Result<std::string> text = read_file(path);
    if (!text.ok()) return text.error();
    return parse_headset_profile(*text, path.string());
}

std::string headset_profile_to_json(const HeadsetProfile& p) {
    using ojson = nlohmann::ordered_json;  // note: keeps the documented field order
    auto rows = [](const glm::dmat3& m) {
        ojson out = ojson::array();
        for (int r = 0; r < 3; ++r) out.push_back({m[0][r], m[1][r], m[2][r]});
        return out;
    };
    ojson j;
    j["version"] = 1;
    j["name"] = p.name;
    j["panel_width"] = p.panel_width;
    j["panel_height"] = p.panel_height;
    j["refresh_hz"] = p.refresh_hz;
    j["eye"] = ojson::array();
    for (const EyeLens& lens : p.eye) {
        ojson e;
        e["model"] = lens_model_name(lens.model);
        ojson ch;
        for (int i = 0; i < 3; ++i) {
            const LensChannel& c = lens.channel[i];
            ch[kChannelNames[i]] = {{"center", {c.center.x, c.center.y}}, {"coeffs", c.coeffs}};
        }
        e["channel"] = ch;
        e["intrinsics"] = rows(lens.intrinsics);
        e["grow_for_undistort"] = lens.grow_for_undistort;
        e["undistort_r2_cutoff"] = lens.undistort_r2_cutoff;
        e["aspect_x_over_y"] = lens.aspect_x_over_y;
        e["eye_to_head"] = rows(lens.eye_to_head);
        e["fov"] = {{"tan_left", lens.fov.tan_left},
                    {"tan_right", lens.fov.tan_right},
                    {"tan_up", lens.fov.tan_up},
                    {"tan_down", lens.fov.tan_down}};
        j["eye"].push_back(e);
    }
    return collapse_number_arrays(j.dump(2)) + "\n";
}

Status save_headset_profile(const HeadsetProfile& p, const std::filesystem::path& path) {
    if (Status s = validate_headset_profile(p, path.string()); !s.ok()) return s;
    return write_file_atomically(path, headset_profile_to_json(p));
}

Result<HeadsetProfile> headset_profile_from_openvr_config(const std::string& text,
                                                          const std::string& source) {
    Result<json> parsed = parse_json(text, source);
    if (!parsed.ok()) return parsed.error();
    const json& j = *parsed;
    Reader rd{source, ""};
    HeadsetProfile p;
    const std::string maker = rd.string(j, "", "manufacturer", false);
    const std::string model = rd.string(j, "", "model_number", false);
    p.name = maker.empty() || model.empty() ? maker + model : maker + " " + model;
    if (p.name.empty()) p.name = source;
    double aspect = 0.0;
    if (const json* dev = rd.member(j, "", "device")) {
        p.panel_width = rd.integer(*dev, "device", "eye_target_width_in_pixels");
        p.panel_height = rd.integer(*dev, "device", "eye_target_height_in_pixels");
        // Only the Vive and Vive Pro configs carry it; Monado's default is 0.9, the Index's W/H.
        aspect = rd.number(*dev, "device", "physical_aspect_x_over_y", 0.0, false);
    }
    // note: the config holds no refresh rate (the Index runs at 80/90/120/144 Hz); keep 90.
    p.refresh_hz = 90.0;
    if (rd.ok() && aspect == 0.0 && p.panel_height > 0)
        aspect = double(p.panel_width) / double(p.panel_height);
    const json* eyes = rd.member(j, "", "tracking_to_eye_transform");
    if (eyes && !eyes->is_array()) rd.fail("tracking_to_eye_transform", "expected an array");
    if (eyes && rd.ok() && eyes->size() != 2)
        rd.fail("tracking_to_eye_transform",
                "expected 2 eyes, got " + std::to_string(eyes->size()));
    const char* const names[3] = {"distortion_red", "distortion", "distortion_blue"};
    for (int e = 0; e < 2 && rd.ok(); ++e) {
        const json& ej = (*eyes)[e];
        const std::string path = "tracking_to_eye_transform[" + std::to_string(e) + "]";
        EyeLens& lens = p.eye[e];
        lens.model = LensModel::vive_dpoly3_scaled;
        for (int i = 0; i < 3 && rd.ok(); ++i) {
            const json* d = rd.member(ej, path, names[i]);
            if (!d) break;
            const std::string dpath = path + "." + names[i];
            const std::string type = rd.string(*d, dpath, "type");
            if (rd.ok() && type != "DISTORT_DPOLY3_SCALED" && type != "DISTORT_DPOLY3")
                rd.fail(dpath + ".type", "unsupported distortion type \"" + type +
                                             "\" (expected DISTORT_DPOLY3_SCALED or DPOLY3)");
            lens.channel[i].center.x = rd.number(*d, dpath, "center_x", 0.0, true);
            lens.channel[i].center.y = rd.number(*d, dpath, "center_y", 0.0, true);
            // The Vive has 8 coeffs with 3 used (DPOLY3); the Index 4 (DPOLY3_SCALED).
            if (const json* c = rd.member(*d, dpath, "coeffs")) {
                const std::vector<double> v = rd.numbers(*c, dpath + ".coeffs", 3, true, 4);
                for (size_t k = 0; k < 4 && k < v.size(); ++k) lens.channel[i].coeffs[k] = v[k];
                if (type == "DISTORT_DPOLY3") lens.channel[i].coeffs[3] = 0.0;
            }
        }
        if (const json* k = rd.member(ej, path, "intrinsics"))
            lens.intrinsics = rd.matrix_rows(*k, path + ".intrinsics");
        // Monado's defaults where a field is absent (vive_config.c, vive_init_defaults).
        lens.grow_for_undistort = rd.number(ej, path, "grow_for_undistort", 0.5, false);
        lens.undistort_r2_cutoff = rd.number(ej, path, "undistort_r2_cutoff", 0.0, false);
        if (const json* r = rd.member(ej, path, "eye_to_head", false))
            lens.eye_to_head = rd.matrix_rows(*r, path + ".eye_to_head");
        lens.aspect_x_over_y = aspect;
        lens.fov = monado_render_fov(lens);
    }
    if (!rd.ok()) return make_error(rd.error);
    if (Status s = validate_headset_profile(p, source); !s.ok()) return s.error();
    return p;
}

HeadsetProfile generic_headset_profile() {
    // A Vive-class panel (1080 x 1200, square pixels) behind a lens whose paraxial view spans
    // tan 0.98 outward, 0.82 nasal and 1.0 up/down; the lens's pincushion (k1 = 0.22, k2 = 0.05)
    // widens that to about 50 deg outward, 42 nasal, 52 up/down at the panel edges, so the image
    // on the panel is barrel-predistorted. Lateral chromatic aberration: blue about 1 % wider
    // than green, red about 0.5 % narrower (the Index's sign, a third of its size). A circular
    // lens edge at paraxial r^2 = 1.4.
    HeadsetProfile p;
    p.name = "generic";
    p.panel_width = 1080;
    p.panel_height = 1200;
    p.refresh_hz = 90.0;
    for (int e = 0; e < 2; ++e) {
        EyeLens& lens = p.eye[e];
        lens.model = LensModel::poly_radial;
        lens.channel[0].coeffs = {0.995, 0.217, 0.05, 0.0};
        lens.channel[1].coeffs = {1.0, 0.22, 0.05, 0.0};
        lens.channel[2].coeffs = {1.008, 0.226, 0.052, 0.0};
        lens.undistort_r2_cutoff = 1.4;
        lens.fov = e == 0 ? EyeFov{-0.98, 0.82, 1.0, -1.0} : EyeFov{-0.82, 0.98, 1.0, -1.0};
    }
    return p;
}

}  // namespace hmdnode
