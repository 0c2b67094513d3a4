// Refinement of a progressive mesh (H. Hoppe, "Progressive meshes", SIGGRAPH 1996; the record's
// form: progressive_mesh.cpp): refine() applies vertex splits to the base mesh while the triangle
// count stays within the one asked for, and rebase_progressive_mesh() makes a later state the
// base. Needs nothing of the simplification engine (compact_primitive.cpp builds the output as
// the engine's snapshots do).
//
// Cost: refine O(base + splits applied) time and O(V + F) memory; rebase the same plus the
// splits kept.
#include <cmath>
#include <cstring>

#include "compact_primitive.hpp"
#include "hmdnode/lod/progressive_mesh.hpp"

namespace hmdnode {

size_t ProgressiveMesh::full_triangles() const {
    size_t n = base_faces.size();
    for (const VertexSplit& s : splits) n += s.faces.size();
    return n;
}

Primitive refine(const ProgressiveMesh& pm, size_t triangles) {
    std::vector<glm::vec3> positions(pm.position_count, glm::vec3(0.0f));
    std::vector<uint32_t> wedge_position(pm.wedge_count, 0);
    std::vector<PmWedge> wedges(pm.wedge_count);
    std::vector<uint32_t> corners(size_t(pm.face_count) * 3, 0);
    std::vector<uint8_t> face_alive(pm.face_count, 0);
    for (const PmVertex& v : pm.base_positions) positions[v.id] = v.position;
    for (const PmWedge& w : pm.base_wedges) wedges[w.id] = w, wedge_position[w.id] = w.position;
    for (const PmFace& f : pm.base_faces) {
        for (int k = 0; k < 3; ++k) corners[3 * size_t(f.id) + k] = f.wedges[k];
        face_alive[f.id] = 1;
    }
    size_t live = pm.base_faces.size();
    for (const VertexSplit& s : pm.splits) {
        if (live + s.faces.size() > triangles) break;
        live += s.faces.size();
        positions[s.removed.id] = s.removed.position;
        positions[s.kept] = s.kept_position;
        for (const PmWedge& w : s.removed_wedges)
            wedges[w.id] = w, wedge_position[w.id] = w.position;
        for (const PmWedge& w : s.kept_wedges) wedges[w.id] = w;
        for (const PmFace& f : s.faces) {
            for (int k = 0; k < 3; ++k) corners[3 * size_t(f.id) + k] = f.wedges[k];
            face_alive[f.id] = 1;
        }
        for (const PmCorner& c : s.corners) corners[c.corner] = c.wedge;
    }
    return lod_detail::compact_primitive(positions, wedge_position, wedges, corners, face_alive,
                                         pm.has_normals, pm.has_uv0, pm.has_uv1, pm.has_colors,
                                         pm.material);
}

ProgressiveMesh rebase_progressive_mesh(const ProgressiveMesh& pm, size_t triangles) {
    size_t live = pm.base_faces.size(), applied = 0;
    while (applied < pm.splits.size() && live + pm.splits[applied].faces.size() <= triangles)
        live += pm.splits[applied++].faces.size();
    if (applied == 0) return pm;
    // The state after `applied` splits, as refine() builds it, plus what is alive.
    std::vector<PmVertex> positions(pm.position_count);
    std::vector<uint8_t> position_alive(pm.position_count, 0);
    std::vector<PmWedge> wedges(pm.wedge_count);
    std::vector<uint8_t> wedge_alive(pm.wedge_count, 0);
    std::vector<PmFace> faces(pm.face_count);
    std::vector<uint8_t> face_alive(pm.face_count, 0);
    for (const PmVertex& v : pm.base_positions) positions[v.id] = v, position_alive[v.id] = 1;
    for (const PmWedge& w : pm.base_wedges) wedges[w.id] = w, wedge_alive[w.id] = 1;
    for (const PmFace& f : pm.base_faces) faces[f.id] = f, face_alive[f.id] = 1;
    for (size_t i = 0; i < applied; ++i) {
        const VertexSplit& s = pm.splits[i];
        positions[s.removed.id] = s.removed, position_alive[s.removed.id] = 1;
        positions[s.kept].position = s.kept_position;
        for (const PmWedge& w : s.removed_wedges) wedges[w.id] = w, wedge_alive[w.id] = 1;
        for (const PmWedge& w : s.kept_wedges) wedges[w.id] = w;
        for (const PmFace& f : s.faces) faces[f.id] = f, face_alive[f.id] = 1;
        for (const PmCorner& c : s.corners) faces[c.corner / 3].wedges[c.corner % 3] = c.wedge;
    }
    ProgressiveMesh out;
    out.has_normals = pm.has_normals, out.has_uv0 = pm.has_uv0, out.has_uv1 = pm.has_uv1;
    out.has_colors = pm.has_colors;
    out.material = pm.material;
    out.position_count = pm.position_count, out.wedge_count = pm.wedge_count;
    out.face_count = pm.face_count;
    for (uint32_t i = 0; i < pm.position_count; ++i)
        if (position_alive[i]) out.base_positions.push_back(positions[i]);
    for (uint32_t i = 0; i < pm.wedge_count; ++i)
        if (wedge_alive[i]) out.base_wedges.push_back(wedges[i]);
    for (uint32_t i = 0; i < pm.face_count; ++i)
        if (face_alive[i]) out.base_faces.push_back(faces[i]);
    out.splits.assign(pm.splits.begin() + std::ptrdiff_t(applied), pm.splits.end());
    return out;
}

}  // namespace hmdnode
