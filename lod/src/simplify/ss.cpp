// SS, "spherical scanning": vertex clustering with a sphere moved over the vertices in order.
//
// Paper: H. Li, S. Kim, "Mesh Simplification Algorithms for Rendering Performance", International
// Journal of Engineering Research and Technology 13(6), 2020, pp. 1110-1119, sec. III.IV (SS): a
// sphere of a given radius visits the vertices in their order; the vertices around the visited one
// that fall inside its sphere are merged into one new vertex; the result is re-triangulated.
//
// Departures from the paper:
// - Target instead of radius: the scan stops as soon as the target is reached, and the radius is
//   the smallest found that reaches it: a geometric sweep from 1e-3 bounding-box diagonals up
//   (factor kSweepFactor) to the first radius that reaches it, then kBisections bisection steps
//   down (each pass on a fresh copy). The smallest radius spreads the merging over the whole
//   surface instead of exhausting it at the start of the scan; the count is not monotonic in the
//   radius (on regular meshes all edges cross the radius at once), hence the sweep.
// - A cluster is grown from the visited vertex over mesh edges (a breadth-first search that only
//   enters not yet clustered vertices inside the sphere), so that its members are connected and
//   can be merged on the connectivity; vertices inside the sphere but not reachable inside it
//   (the other side of a thin part) are left to later spheres, where the paper would weld them.
// - The new vertex is the member nearest the cluster's mean (it stays on the surface, and its
//   attributes are exact), and the members are merged into it by half-edge collapses, repeated
//   while one succeeds, under the link condition, border, seam and flip rules of
//   openmesh_mesh.hpp; a member that cannot be merged stays (no Delaunay re-triangulation) and is
//   free to join a later sphere. As in the paper, scans repeat until one merges nothing.
//
// Cost: one scan is O(V + T) plus O(valence^2) per collapse, a few scans per pass, up to ~25
// passes per target.
// Memory: a copy of the welded mesh per pass, O(V) for the clusters.
#include <algorithm>
#include <cmath>
#include <limits>

#include "algorithms.hpp"
#include "openmesh_mesh.hpp"

namespace hmdnode::lod_detail {
namespace {

using VH = OmMesh::VertexHandle;

constexpr double kSweepFactor = 1.5;
constexpr int kBisections = 6;

}  // namespace

double ss_pass(WeldedMesh& m, double radius, const CollapseRules& rules, size_t stop_faces) {
    OmMesh& mesh = m.mesh;
    const size_t n = mesh.n_vertices();
    std::vector<uint8_t> clustered(n);
    std::vector<VH> members;
    double max_moved = 0.0;
    // Scans repeat while one merges something ("until all points are not in the same grid").
    for (bool changed = true; changed && m.alive_faces > stop_faces;) {
        changed = false;
        std::fill(clustered.begin(), clustered.end(), 0);
        for (size_t s = 0; s < n && m.alive_faces > stop_faces; ++s) {
            const VH vs{int(s)};
            if (clustered[s] || mesh.status(vs).deleted() || mesh.is_isolated(vs)) continue;
            const glm::dvec3 centre = point(mesh, vs);
            members.assign(1, vs);
            clustered[s] = 1;
            for (size_t i = 0; i < members.size(); ++i)
                for (VH u : mesh.vv_range(members[i]))
                    if (!clustered[u.idx()] && glm::distance(point(mesh, u), centre) <= radius) {
                        clustered[u.idx()] = 1;
                        members.push_back(u);
                    }
            if (members.size() < 2) continue;
            glm::dvec3 mean(0.0);
            for (VH u : members) mean += point(mesh, u);
            mean /= double(members.size());
            VH rep = members[0];
            double best = std::numeric_limits<double>::max();
            for (VH u : members) {
                double d = glm::distance(point(mesh, u), mean);
                if (d < best) {
                    best = d;
                    rep = u;
                }
            }
            const glm::dvec3 prep = point(mesh, rep);
            for (bool progress = true; progress && m.alive_faces > stop_faces;) {
                progress = false;
                for (VH u : members) {
                    if (u == rep || mesh.status(u).deleted() || m.alive_faces <= stop_faces)
                        continue;
                    CollapsePlan plan;
                    if (!plan_collapse(m, mesh.find_halfedge(u, rep), nullptr, rules, &plan))
                        continue;
                    max_moved = std::max(max_moved, glm::distance(point(mesh, u), prep));
                    apply_collapse(m, plan);
                    progress = changed = true;
                }
            }
            // Members that could not be merged are free for the spheres that follow.
            for (VH u : members)
                if (u != rep && !mesh.status(u).deleted()) clustered[u.idx()] = 0;
        }
    }
    return max_moved;
}

SimplifiedLevel ss_to_target(const WeldedMesh& base, size_t target, const CollapseRules& rules) {
    glm::dvec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
    for (VH v : base.mesh.vertices()) {
        lo = glm::min(lo, point(base.mesh, v));
        hi = glm::max(hi, point(base.mesh, v));
    }
    const double diag = std::max(glm::distance(lo, hi), 1e-12);
    SimplifiedLevel best{to_primitive(base), -1.0};
    size_t best_faces = base.alive_faces;
    // Sweep up until a radius reaches the target (the count is far from monotonic in the radius
    // on regular meshes), then bisect down between the last radius that did not and that one.
    double r_fail = 0.0, r_ok = 0.0;
    for (double r = diag * 1e-3; r <= diag; r *= kSweepFactor) {
        WeldedMesh m = base;
        double moved = ss_pass(m, r, rules, target);
        if (m.alive_faces <= target) {
            best = {to_primitive(m), moved};
            best_faces = m.alive_faces;
            r_ok = r;
            break;
        }
        r_fail = r;
        if (m.alive_faces < best_faces) {
            best = {to_primitive(m), moved};
            best_faces = m.alive_faces;
        }
    }
    if (r_ok == 0.0) return best;
    for (int it = 0; it < kBisections && r_fail > 0.0; ++it) {
        double r = std::sqrt(r_fail * r_ok);
        WeldedMesh m = base;
        double moved = ss_pass(m, r, rules, target);
        if (m.alive_faces <= target) {
            best = {to_primitive(m), moved};
            r_ok = r;
        } else {
            r_fail = r;
        }
    }
    return best;
}

Result<std::vector<SimplifiedLevel>> simplify_ss(const Primitive& in,
                                                 std::span<const size_t> targets,
                                                 const SimplifyOptions& options) {
    WeldedMesh m = weld_to_openmesh(in, options.locked_positions);
    CollapseRules rules;
    rules.lock_borders = options.lock_borders;
    std::vector<SimplifiedLevel> levels;
    for (size_t i = 0; i < targets.size(); ++i) {
        levels.push_back(ss_to_target(m, targets[i], rules));
        if (options.progress) options.progress(double(i + 1) / double(targets.size()));
    }
    return levels;
}

}  // namespace hmdnode::lod_detail
