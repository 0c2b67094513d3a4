// libFuzzer harness: the progressive-mesh (.hmpm) reader, decode_progressive_mesh, on untrusted
// bytes. Invariants for a file it accepts: encoding it again gives the same bytes, and refine()
// (which trusts what the decoder checked) stays in bounds at the base, half-way and full counts,
// with indices in range and the triangle count between base and full.
//
// Linked to the lod library (tests/fuzz/CMakeLists.txt); of it, only the .hmpm codec
// (progressive_mesh_file.cpp), refine() (progressive_mesh_refine.cpp) and compact_primitive.cpp
// are linked in, none of the simplification engine.
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <span>
#include <vector>

#include "hmdnode/lod/progressive_mesh.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace hmdnode;
    Result<ProgressiveMesh> pm = decode_progressive_mesh(std::span<const uint8_t>(data, size));
    if (!pm.ok()) {
        if (pm.error().message.find("byte ") == std::string::npos) abort();  // names the offset
        return 0;
    }
    const std::vector<uint8_t> again = encode_progressive_mesh(*pm);
    if (again.size() != size || (size && std::memcmp(again.data(), data, size) != 0)) abort();
    const size_t base = pm->base_triangles(), full = pm->full_triangles();
    for (size_t n : {size_t(0), base, (base + full) / 2, full}) {
        const Primitive p = refine(*pm, n);
        if (p.triangle_count() < base || p.triangle_count() > full) abort();
        if (n >= base && p.triangle_count() > n) abort();
        for (uint32_t i : p.indices)
            if (i >= p.positions.size()) abort();
    }
    return 0;
}
