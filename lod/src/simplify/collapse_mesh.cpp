// The mesh both collapse schedules work on: the weld of the input into wedges and positions, the
// faces and the corner lists, the kind of every position (free, border, seam, locked) and the
// collapses those kinds allow on an edge.
//
// Idea: meshoptimizer's simplifier (A. Kapoulkine): identical vertices weld into wedges, wedges
// with the same coordinates into positions; an edge whose two faces hold different wedges at
// either end is a seam edge. A free position has one wedge and no border or seam edge; a border
// position two border edges and one wedge; a seam position two wedges on exactly two seam edges;
// everything else (seam corners and ends, seams on borders, non-manifold positions, the
// positions the caller lists in SimplifyOptions::locked_positions) is locked. Only two free
// positions may merge at a new point; border and seam positions move onto a neighbour along
// their border or seam, so borders, seams and their corners stay exactly where they were.
//
// Cost: O(V + F) time for the weld (open-addressing hash), the faces and the classification
// (O(valence) per position, in two halves on the helper thread when there is one); moves_for()
// is O(1), edge_moves() O(valence).
#include "collapse_mesh.hpp"

#include <algorithm>
#include <cstring>

#include "position_set.hpp"

namespace hmdnode::lod_detail {
namespace {

// Open-addressing hash weld of fixed-size float records: out[i] = id of the first record equal
// (bitwise, -0 == +0) to record i; returns the number of distinct records.
uint32_t weld_records(const Scratch<float>& data, size_t stride, size_t count,
                      Scratch<uint32_t>& out_ids, Scratch<uint32_t>& out_first) {
    size_t cap = 1;
    while (cap < count * 2) cap <<= 1;
    Scratch<uint32_t> table(cap, kNone);
    out_ids.assign(count, kNone);
    out_first.clear();
    for (size_t i = 0; i < count; ++i) {
        const float* r = &data[i * stride];
        uint64_t h = 1469598103934665603ull;
        for (size_t k = 0; k < stride; ++k) {
            uint32_t bits;
            std::memcpy(&bits, &r[k], 4);
            h = (h ^ bits) * 1099511628211ull;
        }
        h ^= h >> 29;
        size_t slot = size_t(h) & (cap - 1);
        for (;;) {
            const uint32_t e = table[slot];
            if (e == kNone) {
                table[slot] = uint32_t(i);
                out_ids[i] = uint32_t(out_first.size());
                out_first.push_back(uint32_t(i));
                break;
            }
            if (std::memcmp(&data[size_t(e) * stride], r, stride * sizeof(float)) == 0) {
                out_ids[i] = out_ids[e];
                break;
            }
            slot = (slot + 1) & (cap - 1);
        }
    }
    return uint32_t(out_first.size());
}

}  // namespace

void EngineCore::build(const Primitive& in) {
    const size_t n = in.positions.size();
    has_normals_ = !in.normals.empty();
    has_uv0_ = !in.uv0.empty();
    has_uv1_ = !in.uv1.empty();
    has_colors_ = !in.colors.empty();
    material_ = in.material;

    // Weld identical vertices into wedges, then wedges into positions.
    const size_t stride = 3 + (has_normals_ ? 3 : 0) + (has_uv0_ ? 2 : 0) + (has_uv1_ ? 2 : 0) +
                          (has_colors_ ? 4 : 0);
    Scratch<float> rec(n * stride);
    for (size_t i = 0; i < n; ++i) {
        float* r = &rec[i * stride];
        auto put = [&r](float x) { *r++ = x + 0.0f; };  // note: + 0.0f turns -0 into +0
        put(in.positions[i].x), put(in.positions[i].y), put(in.positions[i].z);
        if (has_normals_) put(in.normals[i].x), put(in.normals[i].y), put(in.normals[i].z);
        if (has_uv0_) put(in.uv0[i].x), put(in.uv0[i].y);
        if (has_uv1_) put(in.uv1[i].x), put(in.uv1[i].y);
        if (has_colors_)
            put(in.colors[i].x), put(in.colors[i].y), put(in.colors[i].z), put(in.colors[i].w);
    }
    Scratch<uint32_t> vertex_wedge, wedge_source;
    const uint32_t wedge_count = weld_records(rec, stride, n, vertex_wedge, wedge_source);
    Scratch<float> prec(size_t(wedge_count) * 3);
    for (uint32_t w = 0; w < wedge_count; ++w) {
        std::memcpy(&prec[size_t(w) * 3], &rec[size_t(wedge_source[w]) * stride], 12);
    }
    Scratch<uint32_t> position_source, wedge_position;
    const uint32_t position_count =
        weld_records(prec, 3, wedge_count, wedge_position, position_source);
    Scratch<glm::vec3> welded(position_count);
    for (uint32_t p = 0; p < position_count; ++p) {
        welded[p] = in.positions[wedge_source[position_source[p]]];
    }

    // The pass schedule cuts the positions in two regions (split_pass()) at the median of the
    // bounding box's longest axis and numbers each region's positions together (a stable
    // partition of the weld's order), so that the two threads of a split pass write to different
    // cache lines. Wedges and faces keep the input's order, and with them the output.
    m_.bbox_min = m_.bbox_max = welded.empty() ? glm::vec3(0.0f) : welded[0];
    for (const glm::vec3& x : welded) {
        m_.bbox_min = glm::min(m_.bbox_min, x);
        m_.bbox_max = glm::max(m_.bbox_max, x);
    }
    Scratch<uint32_t> new_position(position_count);
    for (uint32_t p = 0; p < position_count; ++p) new_position[p] = p;
    if (flat_ && in.indices.size() / 3 >= kSplitFaces) {
        const glm::vec3 e = m_.bbox_max - m_.bbox_min;
        const int axis = e.x >= e.y && e.x >= e.z ? 0 : e.y >= e.z ? 1 : 2;
        Scratch<float> coordinate(position_count);
        for (uint32_t p = 0; p < position_count; ++p) coordinate[p] = welded[p][axis];
        std::nth_element(coordinate.begin(), coordinate.begin() + position_count / 2,
                         coordinate.end());
        const float median = coordinate[position_count / 2];
        uint32_t next[2] = {0, 0};
        for (uint32_t p = 0; p < position_count; ++p) next[1] += welded[p][axis] < median;
        region_start_ = next[1];
        for (uint32_t p = 0; p < position_count; ++p) {
            new_position[p] = next[welded[p][axis] >= median]++;
        }
    }
    m_.positions.resize(position_count);
    for (uint32_t p = 0; p < position_count; ++p) m_.positions[new_position[p]] = welded[p];
    m_.wedge_position.resize(wedge_count);
    for (uint32_t w = 0; w < wedge_count; ++w) {
        m_.wedge_position[w] = new_position[wedge_position[w]];
    }
    // note: without attributes or a log a wedge is only its position; wedges_ stays empty.
    if (has_normals_ || has_uv0_ || has_uv1_ || has_colors_ || log_) wedges_.resize(wedge_count);
    for (uint32_t w = 0; w < uint32_t(wedges_.size()); ++w) {
        const uint32_t s = wedge_source[w];
        PmWedge& x = wedges_[w];
        x.id = w;
        x.position = m_.wedge_position[w];
        if (has_normals_) x.normal = in.normals[s];
        if (has_uv0_) x.uv0 = in.uv0[s];
        if (has_uv1_) x.uv1 = in.uv1[s];
        if (has_colors_) x.color = in.colors[s];
    }
    // Wedges of each position (CSR).
    wedge_first_.assign(position_count + 1, 0);
    for (uint32_t w = 0; w < wedge_count; ++w) ++wedge_first_[m_.wedge_position[w] + 1];
    for (uint32_t p = 0; p < position_count; ++p) wedge_first_[p + 1] += wedge_first_[p];
    wedge_list_.resize(wedge_count);
    {
        Scratch<uint32_t> fill(wedge_first_.begin(), wedge_first_.end() - 1);
        for (uint32_t w = 0; w < wedge_count; ++w) wedge_list_[fill[m_.wedge_position[w]]++] = w;
    }
    sole_wedge_.resize(position_count);
    for (uint32_t p = 0; p < position_count; ++p) {
        const bool one = wedge_first_[p + 1] - wedge_first_[p] == 1;
        sole_wedge_[p] = one ? wedge_list_[wedge_first_[p]] : kNone;
    }

    // Faces and the corner lists; faces with a repeated position are dropped (zero area, and they
    // would break the link condition).
    const size_t faces = in.indices.size() / 3;
    m_.corners.resize(faces * 3);
    m_.corner_position.resize(faces * 3);
    m_.face_alive.assign(faces, 0);
    // note: the pass schedule keeps flat lists instead of the corner lists.
    const bool lists = !flat_;
    if (lists) {
        m_.corner_head.assign(position_count, kNone);
        m_.corner_next.assign(faces * 3, kNone);
    }
    m_.position_alive.assign(position_count, 0);
    input_normals_.resize(faces);
    // note: by halves of the faces on the pass schedule's helper.
    const size_t face_cut = two_way_.has_helper() ? faces / 2 : faces;
    auto face_half = [this, indices = in.indices.data(), wedge = vertex_wedge.data(), faces,
                      face_cut](int h) {
        size_t live = 0;
        for (size_t f = h == 0 ? 0 : face_cut, end = h == 0 ? face_cut : faces; f < end; ++f) {
            for (int k = 0; k < 3; ++k) {
                const uint32_t w = wedge[indices[3 * f + k]];
                m_.corners[3 * f + k] = w;
                m_.corner_position[3 * f + k] = m_.wedge_position[w];
            }
            input_normals_[f] = glm::vec3(m_.face_normal_unnormalized(uint32_t(f)));
            const uint32_t p0 = m_.face_position(uint32_t(f), 0),
                           p1 = m_.face_position(uint32_t(f), 1),
                           p2 = m_.face_position(uint32_t(f), 2);
            if (p0 == p1 || p1 == p2 || p0 == p2) continue;
            m_.face_alive[f] = 1;
            ++live;
        }
        workers_[h].counted = live;
    };
    two_way_.run(face_half);
    live_faces_ = workers_[0].counted + workers_[1].counted;
    for (size_t c = faces * 3; c-- > 0;) {
        if (!m_.face_alive[c / 3]) continue;
        const uint32_t p = m_.corner_position[c];
        if (lists) {
            m_.corner_next[c] = m_.corner_head[p];
            m_.corner_head[p] = uint32_t(c);
        }
        m_.position_alive[p] = 1;
    }
    m_.lock_borders = options_.lock_borders;
    for (Worker& w : workers_) {
        w.mark.assign(position_count, 0);
        w.slot.assign(position_count, 0);
    }
}

// The edges of position p, grouped by the other endpoint in O(valence): w.groups[i] = one edge
// with its face count and the wedges of its first two faces. Prunes dead corners from p's list.
[[gnu::flatten]] void EngineCore::gather_edges(Worker& w, uint32_t p) {
    w.groups.clear();
    w.first_wedge_at_p = w.other_wedge_at_p = kNone;
    w.more_wedges_at_p = false;
    const uint32_t s = ++w.stamp;
    walk_pruning(p, [&](uint32_t f, int k) {
        const uint32_t c = 3 * f + uint32_t(k);
        const uint32_t wp = m_.corners[c];
        if (w.first_wedge_at_p == kNone) {
            w.first_wedge_at_p = wp;
        } else if (wp != w.first_wedge_at_p) {
            if (w.other_wedge_at_p == kNone) {
                w.other_wedge_at_p = wp;
            } else if (wp != w.other_wedge_at_p) {
                w.more_wedges_at_p = true;
            }
        }
        for (int j = 1; j < 3; ++j) {
            const int kq = k + j < 3 ? k + j : k + j - 3;
            const uint32_t wq = m_.corners[3 * f + kq];
            const uint32_t q = m_.corner_position[3 * f + kq];
            if (w.mark[q] != s) {
                w.mark[q] = s;
                w.slot[q] = uint32_t(w.groups.size());
                w.groups.push_back({q, 0, {f, f}, {wp, wp}, {wq, wq}});
            }
            EdgeGroup& g = w.groups[w.slot[q]];
            if (g.count < 2) g.face[g.count] = f, g.wp[g.count] = wp, g.wq[g.count] = wq;
            ++g.count;
        }
    });
}

// The kind of every position and the constraint edges (in order of their first position), by
// halves of the positions where the pass schedule has a helper.
void EngineCore::classify() {
    const uint32_t np = uint32_t(m_.positions.size());
    m_.kinds.assign(np, VertexKind::Locked);
    m_.on_border.assign(np, 0);
    simple_fan_.assign(flat_ ? np : 0, 0);
    const uint32_t cut = two_way_.has_helper() ? np / 2 : np;
    auto half = [this, np, cut](int h) {
        Worker& w = workers_[h];
        Scratch<ConstraintEdge> edges;  // note: on this thread's stack (see collect_candidates())
        edges.swap(w.constraint_edges);
        for (uint32_t p = h == 0 ? 0 : cut, end = h == 0 ? cut : np; p < end; ++p) {
            if (m_.position_alive[p]) classify_position(w, p, edges);
        }
        edges.swap(w.constraint_edges);
    };
    two_way_.run(half);
    for (Worker& w : workers_) {
        m_.constraint_edges.insert(m_.constraint_edges.end(), w.constraint_edges.begin(),
                                   w.constraint_edges.end());
        w.constraint_edges = {};
    }
    if (!options_.locked_positions.empty()) {
        const PositionSet locked(options_.locked_positions);
        for (uint32_t p = 0; p < np; ++p) {
            if (locked.contains(m_.positions[p])) m_.kinds[p] = VertexKind::Locked;
        }
    }
}

void EngineCore::classify_position(Worker& w, uint32_t p, Scratch<ConstraintEdge>& edges) {
    if (flat_ && classify_simple_fan(w, p)) {
        m_.kinds[p] = VertexKind::Free;
        simple_fan_[p] = 1;
        return;
    }
    gather_edges(w, p);
    // Distinct wedges at p: one, two, or more (3).
    const int wedge_count = w.other_wedge_at_p == kNone ? 1 : w.more_wedges_at_p ? 3 : 2;
    int border_edges = 0, seam_edges = 0;
    bool non_manifold = false;
    for (const EdgeGroup& g : w.groups) {
        if (g.count == 1) {
            ++border_edges;
            if (p < g.q) edges.push_back({p, g.q, g.face[0]});
        } else if (g.count == 2) {
            if (g.wp[0] != g.wp[1] || g.wq[0] != g.wq[1]) {
                ++seam_edges;
                if (p < g.q) {
                    edges.push_back({p, g.q, g.face[0]});
                    edges.push_back({p, g.q, g.face[1]});
                }
            }
        } else {
            non_manifold = true;
        }
    }
    VertexKind kind = VertexKind::Locked;
    if (border_edges > 0) m_.on_border[p] = 1;
    if (non_manifold) {
        kind = VertexKind::Locked;
    } else if (border_edges > 0) {
        if (border_edges == 2 && wedge_count == 1 && seam_edges == 0) kind = VertexKind::Border;
    } else if (wedge_count == 1 && seam_edges == 0) {
        kind = VertexKind::Free;
    } else if (wedge_count == 2 && seam_edges == 2) {
        kind = VertexKind::Seam;
    }
    m_.kinds[p] = kind;
}

// The common case of classify(), on p's flat list: one wedge, and every neighbour q once as the
// `next` of one face and once as the `prev` of another, with the same wedge at q in both (no seam):
// p is free. False: classify() looks closer.
bool EngineCore::classify_simple_fan(Worker& w, uint32_t p) {
    const uint32_t first = adj_first_[p], n = adj_first_[p + 1] - first;
    if (n < 3) return false;
    const AdjEntry* e = &adj_[first];
    const uint32_t w0 = m_.corners[e[0].corner];
    // note: n distinct `next`s, and every `prev` one of them, once: a bijection.
    const uint32_t s_next = ++w.stamp, s_prev = ++w.stamp;
    for (uint32_t i = 0; i < n; ++i) {
        const uint32_t q = e[i].next;
        if (w.mark[q] == s_next || m_.corners[e[i].corner] != w0) return false;
        w.mark[q] = s_next;
        w.slot[q] = i;
    }
    for (uint32_t j = 0; j < n; ++j) {
        const uint32_t q = e[j].prev;
        if (w.mark[q] != s_next) return false;  // not a next, or a prev twice
        w.mark[q] = s_prev;
        // The wedge at q in its two faces (as next of face i, as prev of face j): no seam.
        const uint32_t ci = e[w.slot[q]].corner, fi = ci / 3, ki = ci - 3 * fi;
        const uint32_t cj = e[j].corner, fj = cj / 3, kj = cj - 3 * fj;
        if (m_.corners[3 * fi + (ki == 2 ? 0 : ki + 1)] !=
            m_.corners[3 * fj + (kj == 0 ? 2 : kj - 1)]) {
            return false;
        }
    }
    return true;
}

EdgeMoves EngineCore::edge_moves(uint32_t a, uint32_t b) const {
    EdgeMoves moves;
    const VertexKind ka = m_.kinds[a], kb = m_.kinds[b];
    if (ka == VertexKind::Locked && kb == VertexKind::Locked) return moves;
    int shared = 0;
    uint32_t wa[2] = {kNone, kNone}, wb[2] = {kNone, kNone};
    m_.for_each_face(a, [&](uint32_t f, int k) {
        for (int j = 1; j < 3; ++j) {
            const int kb2 = (k + j) % 3;
            if (m_.face_position(f, kb2) == b) {
                if (shared < 2) {
                    wa[shared] = m_.corners[3 * f + k];
                    wb[shared] = m_.corners[3 * f + kb2];
                }
                ++shared;
            }
        }
    });
    return moves_for(a, b, shared, wa, wb);
}

EdgeMoves EngineCore::moves_for(uint32_t a, uint32_t b, int shared, const uint32_t wa[2],
                                const uint32_t wb[2]) const {
    EdgeMoves moves;
    if (shared == 0 || shared > 2) return moves;
    const VertexKind ka = m_.kinds[a], kb = m_.kinds[b];
    const bool border_edge = shared == 1;
    const bool seam_edge = shared == 2 && (wa[0] != wa[1] || wb[0] != wb[1]);
    auto removable = [&](VertexKind k) {
        switch (k) {
            case VertexKind::Free:
                return true;
            case VertexKind::Border:
                return border_edge && !m_.lock_borders;
            case VertexKind::Seam:
                return seam_edge;
            case VertexKind::Locked:
                return false;
        }
        return false;
    };
    moves.a_to_b = removable(ka);
    moves.b_to_a = removable(kb);
    moves.merge = moves.a_to_b && moves.b_to_a && ka == VertexKind::Free && kb == VertexKind::Free;
    return moves;
}

}  // namespace hmdnode::lod_detail
