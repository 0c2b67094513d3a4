// The edge-collapse engine's output, pinned bit for bit: each algorithm's levels (indices,
// positions, attributes, error estimates) and a progressive mesh's .hmpm bytes on the bundled
// meshes, as FNV-1a hashes. A change to the engine that should not change its decisions (a
// refactor, a new thread layout) must leave them all as they are; a change that means to (a new
// guard, another attribute placement) updates the table here, with the reason in its commit.
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "hmdnode/core/obj.hpp"
#include "hmdnode/lod/progressive_mesh.hpp"
#include "hmdnode/lod/simplify.hpp"

namespace hmdnode {
namespace {

struct Fnv {
    uint64_t h = 1469598103934665603ull;
    void add(const void* data, size_t bytes) {
        const auto* p = static_cast<const unsigned char*>(data);
        for (size_t i = 0; i < bytes; ++i) h = (h ^ p[i]) * 1099511628211ull;
    }
    template <class T>
    void add(const std::vector<T>& v) {
        const uint64_t n = v.size();
        add(&n, sizeof n);
        add(v.data(), v.size() * sizeof(T));
    }
};

uint64_t hash_levels(const std::vector<SimplifiedLevel>& levels) {
    Fnv f;
    for (const SimplifiedLevel& l : levels) {
        const Primitive& p = l.primitive;
        f.add(p.indices), f.add(p.positions), f.add(p.normals), f.add(p.uv0), f.add(p.uv1);
        f.add(p.colors);
        f.add(&l.estimated_error, sizeof l.estimated_error);
    }
    return f.h;
}

Primitive load(const char* name) {
    Result<Mesh> mesh = load_obj(std::string(HMDNODE_SOURCE_DIR "/data/meshes/") + name);
    EXPECT_TRUE(mesh.ok()) << name;
    return mesh.ok() ? mesh->primitives[0] : Primitive{};
}

struct Pinned {
    const char* mesh;
    const char* algorithm;
    uint64_t hash;
};

// Levels at 50 %, 10 % and 1 % of the input's triangles.
const Pinned kPinned[] = {
    {"spot.obj", "qem", 0xe7a8ab85e07a517aull},
    {"spot.obj", "curvature-qem", 0x39234cea0b8f2abdull},
    {"spot.obj", "formula1", 0x0008a5e9bb3cf136ull},
    {"spot.obj", "melax", 0x55db5be34c9258b8ull},
    {"fandisk.obj", "qem", 0x424b094648e621b6ull},
    {"fandisk.obj", "curvature-qem", 0xcd58ad854fa8faa8ull},
    {"fandisk.obj", "formula1", 0xf87a8c1069d910bdull},
    {"fandisk.obj", "melax", 0x0594dab79b9743eaull},
};

std::string hex(uint64_t h) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "0x%016llxull", static_cast<unsigned long long>(h));
    return buf;
}

// With one thread and with a helper (threads = 2), which must not change a bit.
TEST(EngineOutput, LevelsAreBitForBitAsPinned) {
    for (const Pinned& pin : kPinned) {
        const Primitive in = load(pin.mesh);
        const size_t n = in.triangle_count();
        const size_t targets[] = {n / 2, n / 10, n / 100};
        for (unsigned threads : {1u, 2u}) {
            SimplifyOptions options;
            options.threads = threads;
            Result<std::vector<SimplifiedLevel>> r = simplify(in, pin.algorithm, targets, options);
            ASSERT_TRUE(r.ok()) << r.error().message;
            EXPECT_EQ(hex(hash_levels(*r)), hex(pin.hash))
                << pin.mesh << " " << pin.algorithm << " threads " << threads;
        }
    }
}

TEST(EngineOutput, ProgressiveMeshBytesAreAsPinned) {
    const Primitive in = load("fandisk.obj");
    const size_t targets[] = {in.triangle_count() / 10};
    for (unsigned threads : {1u, 2u}) {
        SimplifyOptions options;
        options.threads = threads;
        Result<ProgressiveMeshBuild> built = build_progressive_mesh(in, "qem", targets, options);
        ASSERT_TRUE(built.ok()) << built.error().message;
        Fnv f;
        f.add(encode_progressive_mesh(built->mesh));
        EXPECT_EQ(hex(f.h), hex(0xee32e3b8219a727cull)) << "threads " << threads;
    }
}

}  // namespace
}  // namespace hmdnode
