// Uniform-grid vertex clustering (J. Rossignac, P. Borrel, "Multi-resolution 3D approximations for
// rendering complex scenes", Modeling in Computer Graphics, Springer 1993): the `grid` algorithm of
// `hmdnode lod`, the fastest and coarsest; the edge-collapse methods (QEM, Melax, ...) have a file
// each.
//
// Pure functions over caller-owned data: no I/O, no threads, no globals.
#pragma once

#include <cstddef>

#include "hmdnode/core/scene.hpp"

namespace hmdnode {

// Clusters the vertices of `in` on an axis-aligned grid of cubic cells of edge `cell_size`
// (metres of the primitive's space) anchored at the minimum corner of its bounding box, and
// rebuilds the triangles on one representative vertex per cluster.
//
// - Representative position: the cluster's input vertex nearest the mean of its vertices (stays
//   on the surface, unlike the mean itself on curved parts).
// - Attributes: colours and baked light (_LIGHT_0) averaged over the cluster; uv0/uv1 taken from
// the representative (an
//   average across a UV seam would land between charts); normals recomputed area-weighted from
//   the output triangles, falling back to the renormalised average of the input normals when a
//   vertex has no area around it. Output has exactly the attribute arrays the input has.
// - Triangles whose corners fall in fewer than three clusters, triangles of zero area, and
//   repeated triangles (same corners, same orientation) are dropped; unreferenced clusters are
//   not emitted. Triangle order follows the input; material is kept.
//
// out_max_displacement_m (optional) receives the largest distance from an input vertex to the
// representative of its cluster. It is a cheap proxy of the geometric error, in the primitive's
// units: it bounds how far any input vertex moved, not the distance between the surfaces
// (lod_chain measures the symmetric Hausdorff distance afterwards). It is at most the cell
// diagonal, sqrt(3) * cell_size.
//
// Requires cell_size > 0 and every index < in.positions.size().
Primitive cluster_vertices(const Primitive& in, float cell_size, float* out_max_displacement_m);

struct ClusteredLevel {
    Primitive primitive;
    float cell_size = 0.0f;
    float max_displacement_m = 0.0f;
};

// Finds by bisection (on the logarithm of the cell size, `iterations` steps between
// 1e-4 and 1 bounding-box diagonals) the grid whose output is closest to `target_triangles`,
// and returns that output. The count is not strictly monotonic in the cell size, so the closest
// non-empty result seen is kept, and where every grid tried was empty, the input itself
// (cell_size 0): the output is never empty for a non-empty input, so a small object does not
// vanish from a level where 0 triangles is nearer a target of one or two than the few of the
// coarsest grid that keeps it.
// Requires target_triangles > 0.
ClusteredLevel cluster_to_triangle_count(const Primitive& in, size_t target_triangles,
                                         int iterations = 24);

}  // namespace hmdnode
