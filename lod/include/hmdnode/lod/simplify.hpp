// Mesh simplification: every algorithm `hmdnode lod` offers (those of Lazányi 2003, Li and Kim 2020
// and He et al., and the classics they build on: Garland and Heckbert 1997, Melax 1998, Rossignac
// and Borrel 1993; full citations in docs/references.md) behind one entry point, selectable by name
// (`hmdnode lod --algorithm NAME`). Each algorithm lives in its own file under lod/src/simplify/
// that opens with the paper it implements and its cost; lod/src/simplify/algorithms.hpp is the
// private table.
//
// Functions over caller-owned data, no I/O; `progress` is called on the calling thread. What a
// call uses besides the calling thread and its own heap memory is what the caller asks for:
// - threads: none by default. With SimplifyOptions::threads >= 2, qem and curvature-qem start one
//   helper thread per call on inputs of 8 192 faces or more (below that their work is not split),
//   with a CPU affinity that leaves out the caller's core of the moment, and join it
//   before returning; it sleeps whenever it has no work (lod/src/simplify/two_way.hpp). The result
//   is the same bit for bit with or without it. The other algorithms run on the calling thread
//   only.
// - memory: each call allocates its working arrays, O(V + F), and frees them before it returns
//   (the edge-collapse engine's bytes per face: lod/src/simplify/collapse_mesh.hpp). A caller that
//   simplifies mesh after mesh may pass a SimplifyScratch (SimplifyOptions::scratch): the large
//   arrays then come from it and go back to it, up to 64 MiB kept between calls, freed with the
//   object.
// Nothing is kept between calls but what the caller's SimplifyScratch holds; calls on different
// threads share no state (each with its own SimplifyScratch, or none).
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scene.hpp"

namespace hmdnode {

namespace lod_detail {
struct ScratchCache;
class ScratchScope;
}  // namespace lod_detail

// Working memory that simplify() calls may share, one call at a time: their large arrays are
// taken from it and given back to it (up to 64 MiB kept), so the next call reuses pages already
// mapped instead of faulting them in again. Not thread-safe: one call at a time per object.
class SimplifyScratch {
  public:
    SimplifyScratch();
    ~SimplifyScratch();
    SimplifyScratch(const SimplifyScratch&) = delete;
    SimplifyScratch& operator=(const SimplifyScratch&) = delete;
    // Bytes kept for the next call.
    size_t cached_bytes() const;

  private:
    friend class lod_detail::ScratchScope;
    std::unique_ptr<lod_detail::ScratchCache> cache_;
};

// What one simplify() call did, for callers that watch the engine (tests, benchmarks).
struct SimplifyStats {
    size_t passes = 0;     // qem, curvature-qem: passes of the pass schedule; 0 for the others
    size_t collapses = 0;  // edge-collapse algorithms: collapses applied; 0 for the others
};

// Where one simplify() call's time went, phase by phase, in milliseconds of steady_clock (wall)
// time: filled when SimplifyOptions::profile points at one. qem and curvature-qem (the pass
// schedule) fill every phase when they run on the calling thread alone (threads <= 1, or an input
// below the helper's size); otherwise, and for the other algorithms, only total_ms, collapses and
// passes. Each phase is charged its own time, less that of the phases timed inside it (a snapshot
// taken in the middle of the collapses counts as a snapshot, not as applying). The timers read
// the clock only when there is a profile.
struct SimplifyProfile {
    double setup_ms = 0.0;       // the engine's mesh: welding, classification, quadrics
    double adjacency_ms = 0.0;   // the flat lists of faces around each position, once per pass
    double candidates_ms = 0.0;  // evaluating candidates (every edge, then the touched ones'
                                 // edges each pass) and dropping the stale ones
    double sort_ms = 0.0;        // the radix sort of the candidates, per pass
    double apply_ms = 0.0;       // the collapses in cost order with their checks (fold guard,
                                 // link condition, seams, borders) and the weights of their
                                 // attribute blends, less what follows
    double attributes_ms = 0.0;  // attribute interpolation: the blends the collapses left
                                 // pending, applied after the pass or before a snapshot
    double snapshots_ms = 0.0;   // copying out each level (compact_primitive)
    double other_ms = 0.0;       // the rest of the call: the end, the baked light, the checks
    double total_ms = 0.0;       // the whole call
    size_t collapses = 0;        // as SimplifyStats
    size_t passes = 0;
};

struct SimplifyOptions {
    // Open borders (edges with one face) keep their vertices where they are.
    bool lock_borders = false;
    // Vertices at these positions (bit for bit) are neither removed nor moved. generate_lod_chains
    // passes the positions a primitive shares with another primitive of its mesh: the material
    // boundaries, which then stay closed (both sides keep the same boundary vertices and edges).
    // `grid` clustering ignores it (it keeps no borders or seams at all).
    std::vector<glm::vec3> locked_positions;
    // Called now and then with the fraction of the work done, 0..1.
    std::function<void(double)> progress;
    // For randomised steps, so that runs are reproducible.
    uint32_t seed = 1;
    // Threads qem and curvature-qem may use: 0 or 1 = the calling thread only; 2 or more = one
    // helper thread besides it, from 8 192 input faces on and on a machine with more than one
    // core (they split their work in two halves, so the result is the same bit for bit either
    // way). The other algorithms run on the calling thread.
    unsigned threads = 1;
    // Working memory reused across calls (see SimplifyScratch); nullptr: the call allocates its
    // own and frees it before returning.
    SimplifyScratch* scratch = nullptr;
    // Filled, when not null, by the edge-collapse algorithms (the figures of the last primitive
    // simplified).
    SimplifyStats* stats = nullptr;
    // Filled, when not null, with where the call's time went (see SimplifyProfile); no clock is
    // read without one.
    SimplifyProfile* profile = nullptr;
};

struct SimplifiedLevel {
    Primitive primitive;
    // The algorithm's own estimate of the geometric error, in the primitive's units (metres of
    // its space), or a negative number when it has none. The measured error comes from
    // mesh_distance.hpp.
    double estimated_error = -1.0;
};

struct AlgorithmInfo {
    std::string name;            // as given to --algorithm: "qem", "curvature-qem", "formula1", ...
    std::string summary;         // one line for --help
    std::string source;          // the paper (and formula) it implements, author-year
    bool edge_collapse = false;  // true: ordered edge collapses, so progressive meshes and --step
};

// Every algorithm, in the order --help lists them.
const std::vector<AlgorithmInfo>& simplification_algorithms();
// nullptr when there is no algorithm of that name.
const AlgorithmInfo* find_simplification_algorithm(std::string_view name);

// Simplifies `in` (an indexed triangle list; split vertices at UV / normal / colour seams are
// welded by position inside and the seams kept) once per target, targets in triangles, strictly
// decreasing, each below in.triangle_count(). Returns one level per target, in the same order,
// each with at most max(target, what the algorithm can reach) triangles: an algorithm that cannot
// reach a target (clustering granularity, locked borders, seams) returns the closest it reached.
// Edge-collapse algorithms make all levels in one pass. Each level has exactly the attribute
// arrays of the input: normals, UVs and colours by the algorithm's own vertex correspondence, the
// baked light (_LIGHT_0) by grid's cluster average or else filtered from the input onto the
// finished level (carry_vertex_light, attribute_transfer.hpp). Errors: unknown algorithm, empty
// input, targets not strictly decreasing or zero.
Result<std::vector<SimplifiedLevel>> simplify(const Primitive& in, std::string_view algorithm,
                                              std::span<const size_t> target_triangles,
                                              const SimplifyOptions& options = {});

}  // namespace hmdnode
