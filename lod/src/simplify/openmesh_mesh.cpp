// Primitive <-> OpenMesh conversion, checked half-edge collapse and the greedy driver shared by the
// algorithms of H. Li, S. Kim, "Mesh Simplification Algorithms for Rendering Performance",
// International Journal of Engineering Research and Technology 13(6), 2020 (see openmesh_mesh.hpp
// for the contract).
//
// No paper: plumbing. The collapse is Hoppe's half-edge collapse (H. Hoppe, "Progressive meshes",
// SIGGRAPH 1996, sec. 3) restricted by the link condition (T. Dey, H. Edelsbrunner, S. Guha,
// D. Nekhayev, "Topology preserving edge contraction", Publications de l'Institut Mathematique
// (Beograd) 66(80), 1999) that OpenMesh checks, plus seam and flip rules of our own (see the
// header).
//
// Cost: welding O(V + T) expected (hash maps); a collapse check O(valence^2); the greedy driver
// O(n log n) over its queue. Memory: the OpenMesh mesh, 3 corners per face, a copy of the input
// attributes.
#include "openmesh_mesh.hpp"
#include "position_set.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>
#include <limits>
#include <queue>
#include <string>
#include <unordered_map>

namespace hmdnode::lod_detail {
namespace {

using VH = OmMesh::VertexHandle;
using FH = OmMesh::FaceHandle;
using HH = OmMesh::HalfedgeHandle;

float canon(float x) {
    return x == 0.0f ? 0.0f : x;
}  // +0 == -0

template <class T>
void append_bytes(std::string& s, const T& v) {
    s.append(reinterpret_cast<const char*>(&v), sizeof(v));
}

}  // namespace

glm::dvec3 point(const OmMesh& mesh, VH v) {
    const auto& p = mesh.point(v);
    return {p[0], p[1], p[2]};
}

void face_corners(const OmMesh& mesh, FH f, VH v[3], glm::dvec3 p[3]) {
    int k = 0;
    for (VH u : mesh.fv_range(f)) {
        v[k] = u;
        p[k++] = point(mesh, u);
    }
}

glm::dvec3 face_normal(const OmMesh& mesh, FH f) {
    auto it = mesh.cfv_iter(f);
    glm::dvec3 a = point(mesh, *it);
    ++it;
    glm::dvec3 b = point(mesh, *it);
    ++it;
    glm::dvec3 c = point(mesh, *it);
    return glm::cross(b - a, c - a);
}

WeldedMesh weld_to_openmesh(const Primitive& in, std::span<const glm::vec3> locked_positions) {
    WeldedMesh m;
    const PositionSet locked(locked_positions);
    const size_t n = in.positions.size();
    std::unordered_map<std::string, uint32_t> wedge_of_key;
    std::unordered_map<std::string, int> vertex_of_pos;
    wedge_of_key.reserve(n);
    vertex_of_pos.reserve(n);
    std::vector<uint32_t> wedge(n);
    std::vector<int> vertex(n);
    std::vector<uint32_t> first_input;  // wedge -> an input vertex
    for (size_t i = 0; i < n; ++i) {
        glm::vec3 p(canon(in.positions[i].x), canon(in.positions[i].y), canon(in.positions[i].z));
        std::string key;
        append_bytes(key, p);
        auto [vit, vnew] = vertex_of_pos.try_emplace(key, -1);
        if (vnew) {
            const OmMesh::VertexHandle vh = m.mesh.add_vertex(OmMesh::Point(p.x, p.y, p.z));
            vit->second = vh.idx();
            if (!locked.empty() && locked.contains(p)) m.mesh.status(vh).set_locked(true);
        }
        vertex[i] = vit->second;
        if (!in.normals.empty()) append_bytes(key, in.normals[i]);
        if (!in.uv0.empty()) append_bytes(key, in.uv0[i]);
        if (!in.uv1.empty()) append_bytes(key, in.uv1[i]);
        if (!in.colors.empty()) append_bytes(key, in.colors[i]);
        auto [wit, wnew] = wedge_of_key.try_emplace(key, uint32_t(first_input.size()));
        if (wnew) first_input.push_back(uint32_t(i));
        wedge[i] = wit->second;
    }
    const size_t w = first_input.size();
    m.wedges.material = in.material;
    m.wedges.positions.resize(w);
    for (size_t j = 0; j < w; ++j) m.wedges.positions[j] = in.positions[first_input[j]];
    auto copy = [&](const auto& src, auto& dst) {
        if (src.empty()) return;
        dst.resize(w);
        for (size_t j = 0; j < w; ++j) dst[j] = src[first_input[j]];
    };
    copy(in.normals, m.wedges.normals);
    copy(in.uv0, m.wedges.uv0);
    copy(in.uv1, m.wedges.uv1);
    copy(in.colors, m.wedges.colors);

    // note: OpenMesh reports refused faces on omerr; we count them instead.
    bool was_enabled = omerr().is_enabled();
    omerr().disable();
    for (size_t t = 0; t + 2 < in.indices.size(); t += 3) {
        uint32_t i0 = in.indices[t], i1 = in.indices[t + 1], i2 = in.indices[t + 2];
        assert(i0 < n && i1 < n && i2 < n);
        int a = vertex[i0], b = vertex[i1], c = vertex[i2];
        if (a == b || b == c || a == c) {
            ++m.rejected_faces;
            continue;
        }
        FH f = m.mesh.add_face(VH(a), VH(b), VH(c));
        if (!f.is_valid()) {
            ++m.rejected_faces;
            continue;
        }
        assert(size_t(f.idx()) == m.corners.size());
        m.corners.push_back({Corner{a, wedge[i0]}, Corner{b, wedge[i1]}, Corner{c, wedge[i2]}});
    }
    if (was_enabled) omerr().enable();
    m.alive_faces = m.corners.size();
    return m;
}

uint32_t wedge_at(const WeldedMesh& m, FH f, VH v) {
    for (const Corner& c : m.corners[f.idx()])
        if (c.vertex == v.idx()) return c.wedge;
    assert(false && "vertex not in face");
    return 0;
}

Primitive to_primitive(const WeldedMesh& m) {
    Primitive out;
    out.material = m.wedges.material;
    std::vector<uint32_t> out_index(m.wedges.positions.size(), UINT32_MAX);
    std::vector<uint32_t> emitted;  // output vertex -> wedge
    std::vector<int> owner;         // output vertex -> OpenMesh vertex
    for (FH f : m.mesh.faces()) {
        if (m.mesh.status(f).deleted()) continue;
        for (VH v : m.mesh.fv_range(f)) {
            uint32_t w = wedge_at(m, f, v);
            if (out_index[w] == UINT32_MAX) {
                out_index[w] = uint32_t(emitted.size());
                emitted.push_back(w);
                owner.push_back(v.idx());
            }
            out.indices.push_back(out_index[w]);
        }
    }
    const size_t k = emitted.size();
    out.positions.resize(k);
    for (size_t j = 0; j < k; ++j) {
        const auto& p = m.mesh.point(VH(owner[j]));
        out.positions[j] = glm::vec3(p[0], p[1], p[2]);
    }
    auto copy = [&](const auto& src, auto& dst) {
        if (src.empty()) return;
        dst.resize(k);
        for (size_t j = 0; j < k; ++j) dst[j] = src[emitted[j]];
    };
    copy(m.wedges.normals, out.normals);
    copy(m.wedges.uv0, out.uv0);
    copy(m.wedges.uv1, out.uv1);
    copy(m.wedges.colors, out.colors);
    return out;
}

bool plan_collapse(const WeldedMesh& m, HH h, const glm::dvec3* placement,
                   const CollapseRules& rules, CollapsePlan* out) {
    const OmMesh& mesh = m.mesh;
    if (!h.is_valid() || mesh.status(mesh.edge_handle(h)).deleted()) return false;
    VH v0 = mesh.from_vertex_handle(h), v1 = mesh.to_vertex_handle(h);
    // note: is_collapse_ok is not const in this OpenMesh, but does not modify the mesh.
    if (!const_cast<OmMesh&>(mesh).is_collapse_ok(h)) return false;
    if (mesh.status(v0).locked()) return false;  // SimplifyOptions::locked_positions
    const bool b0 = mesh.is_boundary(v0), b1 = mesh.is_boundary(v1);
    if (b0 && (rules.lock_borders || !mesh.is_boundary(mesh.edge_handle(h)))) return false;

    CollapsePlan plan;
    plan.h = h;
    plan.v0 = v0;
    plan.v1 = v1;
    FH fl = mesh.face_handle(h), fr = mesh.face_handle(mesh.opposite_halfedge_handle(h));
    for (FH f : {fl, fr}) {
        if (!f.is_valid()) continue;
        ++plan.removed_faces;
        uint32_t w0 = wedge_at(m, f, v0), w1 = wedge_at(m, f, v1);
        bool found = false;
        for (auto& [a, b] : plan.wedge_map)
            if (a == w0) {
                if (b != w1) return false;  // v0 continuous across the edge, v1 not
                found = true;
            }
        if (!found) plan.wedge_map.emplace_back(w0, w1);
    }
    auto mapped = [&](uint32_t w0) {
        for (auto& [a, b] : plan.wedge_map)
            if (a == w0) return true;
        return false;
    };
    for (FH f : mesh.vf_range(v0))
        if (!mapped(wedge_at(m, f, v0))) return false;  // a seam of v0 leaves along another edge

    const glm::dvec3 p0 = point(mesh, v0), p1 = point(mesh, v1);
    glm::dvec3 target = p1;
    if (placement && !b0 && !b1 && !mesh.status(v1).locked()) {
        std::vector<uint32_t> v1_wedges;
        for (FH f : mesh.vf_range(v1)) {
            uint32_t w1 = wedge_at(m, f, v1);
            if (std::find(v1_wedges.begin(), v1_wedges.end(), w1) == v1_wedges.end())
                v1_wedges.push_back(w1);
        }
        bool ok = true;
        for (uint32_t w1 : v1_wedges) {
            bool hit = false;
            for (auto& [a, b] : plan.wedge_map) hit |= b == w1;
            ok &= hit;
        }
        const glm::dvec3 p = *placement;
        if (ok && v1_wedges.size() > 1) {  // on a seam: only along the edge
            glm::dvec3 e = p0 - p1;
            double ee = glm::dot(e, e);
            double t = ee > 0.0 ? glm::dot(p - p1, e) / ee : 0.0;
            ok = t >= 0.0 && t <= 1.0 && glm::distance(p1 + t * e, p) <= 1e-6 * std::sqrt(ee);
        }
        if (ok) {
            // Barycentric coordinates of p in each face of the edge (projected on its plane).
            for (FH f : {fl, fr}) {
                if (!f.is_valid()) continue;
                VH c[3];
                int k = 0;
                for (VH u : mesh.fv_range(f)) c[k++] = u;
                glm::dvec3 a = point(mesh, c[0]), b = point(mesh, c[1]), d = point(mesh, c[2]);
                glm::dvec3 n = glm::cross(b - a, d - a);
                double nn = glm::dot(n, n);
                if (!(nn > 0.0)) continue;
                CollapsePlan::Interpolation in;
                in.w[0] = float(glm::dot(glm::cross(d - b, p - b), n) / nn);
                in.w[1] = float(glm::dot(glm::cross(a - d, p - d), n) / nn);
                in.w[2] = 1.0f - in.w[0] - in.w[1];
                for (int j = 0; j < 3; ++j) in.src[j] = wedge_at(m, f, c[j]);
                in.dst = wedge_at(m, f, v1);
                bool inside = std::min({in.w[0], in.w[1], in.w[2]}) >= -1e-4f;
                auto same = std::find_if(plan.interpolation.begin(), plan.interpolation.end(),
                                         [&](const auto& x) { return x.dst == in.dst; });
                if (same == plan.interpolation.end())
                    plan.interpolation.push_back(in);
                else if (inside)
                    *same = in;  // note: prefer the face that contains p
            }
            plan.move = true;
            target = p;
        }
    }
    plan.target = target;

    // Flips and degeneracies of the faces that survive, around v0 and (when moving) v1.
    const bool has_normals = !m.wedges.normals.empty();
    auto check = [&](VH v) -> bool {
        for (FH f : mesh.vf_range(v)) {
            if (f == fl || f == fr) continue;
            glm::dvec3 q[3];
            glm::dvec3 ref(0.0);  // sum of the corners' attribute normals, when there are some
            int k = 0;
            for (VH u : mesh.fv_range(f)) {
                glm::dvec3 pu = point(mesh, u);
                q[k++] = (u == v0 || u == v1) ? target : pu;
                if (has_normals) {
                    uint32_t w = wedge_at(m, f, u);
                    if (u == v0)
                        for (auto& [a, b] : plan.wedge_map)
                            if (a == w) w = b;
                    ref += glm::dvec3(m.wedges.normals[w]);
                }
            }
            glm::dvec3 e1 = q[1] - q[0], e2 = q[2] - q[0];
            glm::dvec3 nn = glm::cross(e1, e2);
            double ln = glm::length(nn);
            double longest =
                std::max({glm::dot(e1, e1), glm::dot(e2, e2), glm::dot(q[2] - q[1], q[2] - q[1])});
            if (!(ln > 1e-4 * longest)) return false;
            glm::dvec3 no = face_normal(mesh, f);
            double lo = glm::length(no);
            if (lo <= 0.0) continue;  // already degenerate: nothing to flip
            double c = glm::dot(no, nn) / (lo * ln);
            if (c <= rules.min_normal_cos) return false;
            if (has_normals && rules.min_normal_cos > -1.0 && glm::dot(ref, nn) <= 0.0)
                return false;  // faces away from the input's normals
            plan.min_cos = std::min(plan.min_cos, c);
        }
        return true;
    };
    if (!check(v0)) return false;
    if (plan.move && !check(v1)) return false;
    *out = std::move(plan);
    return true;
}

CollapsePlan forced_plan(const WeldedMesh& m, HH h) {
    const OmMesh& mesh = m.mesh;
    CollapsePlan plan;
    plan.h = h;
    plan.v0 = mesh.from_vertex_handle(h);
    plan.v1 = mesh.to_vertex_handle(h);
    plan.target = point(mesh, plan.v1);
    for (FH f : {mesh.face_handle(h), mesh.face_handle(mesh.opposite_halfedge_handle(h))}) {
        if (!f.is_valid()) continue;
        ++plan.removed_faces;
        uint32_t w0 = wedge_at(m, f, plan.v0), w1 = wedge_at(m, f, plan.v1);
        bool found = false;
        for (auto& [a, b] : plan.wedge_map) found |= a == w0;
        if (!found) plan.wedge_map.emplace_back(w0, w1);
    }
    if (plan.wedge_map.empty()) return plan;
    const uint32_t fallback = plan.wedge_map[0].second;
    for (FH f : mesh.vf_range(plan.v0)) {
        uint32_t w0 = wedge_at(m, f, plan.v0);
        bool found = false;
        for (auto& [a, b] : plan.wedge_map) found |= a == w0;
        if (!found) plan.wedge_map.emplace_back(w0, fallback);
    }
    return plan;
}

void prepare_collapse(WeldedMesh& m, const CollapsePlan& plan) {
    const OmMesh& mesh = m.mesh;
    FH fl = mesh.face_handle(plan.h), fr = mesh.face_handle(mesh.opposite_halfedge_handle(plan.h));
    for (FH f : mesh.vf_range(plan.v0)) {
        if (f == fl || f == fr) continue;
        for (Corner& c : m.corners[f.idx()]) {
            if (c.vertex != plan.v0.idx()) continue;
            c.vertex = plan.v1.idx();
            for (auto& [a, b] : plan.wedge_map)
                if (a == c.wedge) {
                    c.wedge = b;
                    break;
                }
        }
    }
}

void finish_collapse(WeldedMesh& m, const CollapsePlan& plan) {
    m.alive_faces -= size_t(plan.removed_faces);
    if (!plan.move) return;
    m.mesh.set_point(
        plan.v1, OmMesh::Point(float(plan.target.x), float(plan.target.y), float(plan.target.z)));
    Primitive& w = m.wedges;
    auto mix3 = [](const auto& arr, const CollapsePlan::Interpolation& in) {
        return in.w[0] * arr[in.src[0]] + in.w[1] * arr[in.src[1]] + in.w[2] * arr[in.src[2]];
    };
    // note: compute every new value from the old ones before assigning any.
    std::vector<glm::vec3> nrm(plan.interpolation.size());
    std::vector<glm::vec2> uv0(nrm.size()), uv1(nrm.size());
    std::vector<glm::vec4> col(nrm.size());
    for (size_t i = 0; i < nrm.size(); ++i) {
        const auto& in = plan.interpolation[i];
        if (!w.normals.empty()) {
            glm::vec3 n = mix3(w.normals, in);
            float l = glm::length(n);
            nrm[i] = l > 0.0f ? n / l : w.normals[in.dst];
        }
        if (!w.uv0.empty()) uv0[i] = mix3(w.uv0, in);
        if (!w.uv1.empty()) uv1[i] = mix3(w.uv1, in);
        if (!w.colors.empty()) col[i] = mix3(w.colors, in);
    }
    for (size_t i = 0; i < nrm.size(); ++i) {
        uint32_t d = plan.interpolation[i].dst;
        if (!w.normals.empty()) w.normals[d] = nrm[i];
        if (!w.uv0.empty()) w.uv0[d] = uv0[i];
        if (!w.uv1.empty()) w.uv1[d] = uv1[i];
        if (!w.colors.empty()) w.colors[d] = col[i];
    }
}

void apply_collapse(WeldedMesh& m, const CollapsePlan& plan) {
    prepare_collapse(m, plan);
    m.mesh.collapse(plan.h);
    finish_collapse(m, plan);
}

glm::dvec3 clamped_circumcenter(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
    glm::dvec3 u = b - a, w = c - a;
    if (glm::dot(u, w) <= 0.0) return 0.5 * (b + c);
    if (glm::dot(a - b, c - b) <= 0.0) return 0.5 * (a + c);
    if (glm::dot(a - c, b - c) <= 0.0) return 0.5 * (a + b);
    glm::dvec3 n = glm::cross(u, w);
    double nn = glm::dot(n, n);
    if (!(nn > 0.0)) return (a + b + c) / 3.0;
    return a + (glm::dot(w, w) * glm::cross(n, u) + glm::dot(u, u) * glm::cross(w, n)) / (2.0 * nn);
}

namespace {

HH find_halfedge(const OmMesh& mesh, VH from, VH to) {
    return mesh.find_halfedge(from, to);
}

// note: a cost depends on the two rings around an element, but re-costing two rings made FAD
// several times slower for no visible change (docs/simplification.md, "Measurements behind the
// engine's choices"); apply() re-checks every collapse anyway, so a stale cost only misorders,
// never breaks the mesh.
constexpr int kRings = 1;

}  // namespace

bool collapse_triangle(WeldedMesh& m, FH f, const glm::dvec3& c, const CollapseRules& rules,
                       VH* out_survivor) {
    if (m.mesh.status(f).deleted()) return false;
    VH v[3];
    int k = 0;
    for (VH u : m.mesh.fv_range(f)) v[k++] = u;
    // Survivors nearest c first; a first pass moves the survivor to c, a second (when no vertex
    // may move there: seams, borders) keeps it where it is.
    std::sort(v, v + 3, [&](VH a, VH b) {
        return glm::distance(point(m.mesh, a), c) < glm::distance(point(m.mesh, b), c);
    });
    for (int pass = 0, s = 0; pass < 2; s = (s + 1) % 3, pass += s == 0) {
        VH keep = v[s], x = v[(s + 1) % 3], y = v[(s + 2) % 3];
        CollapsePlan p1;
        if (!plan_collapse(m, find_halfedge(m.mesh, x, keep), pass == 0 ? &c : nullptr, rules, &p1))
            continue;
        if (pass == 0 && !p1.move) continue;  // the survivor could not go to c
        apply_collapse(m, p1);
        CollapsePlan p2;
        if (plan_collapse(m, find_halfedge(m.mesh, y, keep), nullptr, rules, &p2))
            apply_collapse(m, p2);
        *out_survivor = keep;
        return true;
    }
    return false;
}

bool collapse_edge_to_point(WeldedMesh& m, VH a, VH b, const glm::dvec3& p,
                            const CollapseRules& rules, VH* out_survivor) {
    CollapsePlan plan;
    HH ab = find_halfedge(m.mesh, a, b), ba = find_halfedge(m.mesh, b, a);
    for (int pass = 0; pass < 2; ++pass) {
        for (HH h : {ab, ba}) {
            if (!plan_collapse(m, h, pass == 0 ? &p : nullptr, rules, &plan)) continue;
            if (pass == 0 && !plan.move) continue;
            apply_collapse(m, plan);
            *out_survivor = plan.v1;
            return true;
        }
    }
    return false;
}

std::vector<SimplifiedLevel> run_greedy(WeldedMesh& m, std::span<const size_t> targets,
                                        const GreedyHooks& hooks, const SimplifyOptions& options,
                                        double stop_cost) {
    OmMesh& mesh = m.mesh;
    size_t count = hooks.kind == ElementKind::Vertex ? mesh.n_vertices()
                   : hooks.kind == ElementKind::Edge ? mesh.n_edges()
                                                     : mesh.n_faces();
    struct Entry {
        double cost;
        int idx;
        uint32_t stamp;
        bool operator<(const Entry& o) const { return cost > o.cost; }  // min-heap
    };
    std::vector<uint32_t> stamp(count, 0);
    std::priority_queue<Entry> queue;
    auto deleted = [&](int i) {
        switch (hooks.kind) {
            case ElementKind::Vertex:
                return mesh.status(VH(i)).deleted();
            case ElementKind::Edge:
                return mesh.status(OmMesh::EdgeHandle(i)).deleted();
            case ElementKind::Face:
                return mesh.status(FH(i)).deleted();
        }
        return true;
    };
    auto push = [&](int i) {
        if (deleted(i)) return;
        ++stamp[i];
        double c = hooks.cost(i);
        if (c < 1e300) queue.push({c, i, stamp[i]});
    };
    for (size_t i = 0; i < count; ++i) push(int(i));

    std::vector<SimplifiedLevel> levels;
    size_t next = 0;
    const size_t start = std::max<size_t>(m.alive_faces, 1);
    std::vector<int> ring;
    std::vector<uint32_t> mark(mesh.n_vertices(), 0);
    uint32_t epoch = 0;
    size_t ops = 0;
    while (next < targets.size() && !queue.empty()) {
        while (next < targets.size() && m.alive_faces <= targets[next]) {
            levels.push_back({to_primitive(m), -1.0});
            ++next;
        }
        if (next >= targets.size()) break;
        Entry e = queue.top();
        queue.pop();
        if (e.stamp != stamp[e.idx] || deleted(e.idx)) continue;
        if (e.cost > stop_cost) break;
        VH survivor;
        if (!hooks.apply(e.idx, &survivor)) continue;
        if (options.progress && (++ops & 1023) == 0 && start > targets.back())
            options.progress(
                std::min(1.0, double(start - m.alive_faces) / double(start - targets.back())));
        if (!survivor.is_valid() || mesh.status(survivor).deleted()) continue;
        // The ring of vertices around the survivor (its 1-ring: the vertices whose fan changed).
        ++epoch;
        ring.clear();
        ring.push_back(survivor.idx());
        mark[survivor.idx()] = epoch;
        for (int r = 0, begin = 0; r < kRings; ++r) {
            int end = int(ring.size());
            for (int i = begin; i < end; ++i)
                for (VH u : mesh.vv_range(VH(ring[i])))
                    if (mark[u.idx()] != epoch) {
                        mark[u.idx()] = epoch;
                        ring.push_back(u.idx());
                    }
            begin = end;
        }
        switch (hooks.kind) {
            case ElementKind::Vertex:
                for (int v : ring) push(v);
                break;
            case ElementKind::Edge:
                for (int v : ring)
                    for (auto eh : mesh.ve_range(VH(v))) push(eh.idx());  // note: repeats are cheap
                break;
            case ElementKind::Face:
                for (int v : ring)
                    for (FH f : mesh.vf_range(VH(v))) push(f.idx());
                break;
        }
    }
    while (levels.size() < targets.size()) levels.push_back({to_primitive(m), -1.0});
    return levels;
}

}  // namespace hmdnode::lod_detail
