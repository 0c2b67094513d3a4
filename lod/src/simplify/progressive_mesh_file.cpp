// The progressive-mesh file (.hmpm): encode_progressive_mesh / decode_progressive_mesh and their
// file forms. Apart from the builder (progressive_mesh.cpp), so that reading and writing the
// format needs nothing of the simplification engine (the .hmpm fuzzer, tests/fuzz).
//
// Format: "HMPM", version 1, then the base mesh and the vertex splits (H. Hoppe, "Progressive
// meshes", SIGGRAPH 1996, with the departures progressive_mesh.cpp names), all little-endian; the
// decoder replays the splits against the state they apply to and rejects inconsistent ones,
// naming the byte offset.
//
// Cost: encode and decode O(file size) time; decode O(V + F) memory for the replayed state.
#include <cstring>
#include <string>

#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/lod/progressive_mesh.hpp"

namespace hmdnode {
namespace {

constexpr char kMagic[4] = {'H', 'M', 'P', 'M'};
constexpr uint32_t kVersion = 1;

class Writer {
  public:
    void u32(uint32_t v) {
        for (int i = 0; i < 4; ++i) bytes.push_back(uint8_t(v >> (8 * i)));
    }
    void f32(float f) {
        uint32_t v;
        std::memcpy(&v, &f, 4);
        u32(v);
    }
    void vec(const float* p, int n) {
        for (int i = 0; i < n; ++i) f32(p[i]);
    }
    std::vector<uint8_t> bytes;
};

class Reader {
  public:
    explicit Reader(std::span<const uint8_t> b) : bytes_(b) {}
    size_t offset() const { return pos_; }
    bool u32(uint32_t& v) {
        if (bytes_.size() - pos_ < 4) return false;
        v = 0;
        for (int i = 0; i < 4; ++i) v |= uint32_t(bytes_[pos_ + i]) << (8 * i);
        pos_ += 4;
        return true;
    }
    bool u8(uint8_t& v) {
        if (bytes_.size() - pos_ < 1) return false;
        v = bytes_[pos_++];
        return true;
    }
    bool f32(float& f) {
        uint32_t v;
        if (!u32(v)) return false;
        std::memcpy(&f, &v, 4);
        return true;
    }
    bool at_end() const { return pos_ == bytes_.size(); }
    size_t size() const { return bytes_.size(); }

  private:
    std::span<const uint8_t> bytes_;
    size_t pos_ = 0;
};

Error corrupt(size_t offset, const std::string& what) {
    return make_error("progressive mesh: byte " + std::to_string(offset) + ": " + what);
}

void write_attributes(Writer& w, const ProgressiveMesh& pm, const PmWedge& x) {
    if (pm.has_normals) w.vec(&x.normal.x, 3);
    if (pm.has_uv0) w.vec(&x.uv0.x, 2);
    if (pm.has_uv1) w.vec(&x.uv1.x, 2);
    if (pm.has_colors) w.vec(&x.color.x, 4);
}

// Decoding with the state of the mesh it applies to, to reject inconsistent splits.
class Decoder {
  public:
    explicit Decoder(std::span<const uint8_t> bytes) : r_(bytes) {}

    Result<ProgressiveMesh> decode() {
        ProgressiveMesh pm;
        char magic[4];
        for (char& c : magic) {
            uint8_t b;
            if (!r_.u8(b)) return truncated();
            c = char(b);
        }
        if (std::memcmp(magic, kMagic, 4) != 0) return corrupt(0, "not a progressive mesh (magic)");
        uint32_t version, flags, material, nbp, nbw, nbf, nsplits;
        if (!r_.u32(version)) return truncated();
        if (version != kVersion) {
            return corrupt(
                4, "version " + std::to_string(version) + ", expected " + std::to_string(kVersion));
        }
        if (!r_.u32(flags)) return truncated();
        if (flags > 15) return corrupt(8, "unknown attribute flags " + std::to_string(flags));
        pm.has_normals = flags & 1, pm.has_uv0 = flags & 2, pm.has_uv1 = flags & 4;
        pm.has_colors = flags & 8;
        if (!r_.u32(material)) return truncated();
        pm.material = int(int32_t(material));
        if (!r_.u32(pm.position_count) || !r_.u32(pm.wedge_count) || !r_.u32(pm.face_count) ||
            !r_.u32(nbp) || !r_.u32(nbw) || !r_.u32(nbf) || !r_.u32(nsplits)) {
            return truncated();
        }
        // note: a count larger than the remaining bytes could hold is corrupt; checking it here
        // keeps a forged header from allocating gigabytes.
        const size_t remaining = r_.size() - r_.offset();
        if (pm.position_count > remaining || pm.wedge_count > remaining ||
            pm.face_count > remaining || nbp > remaining || nbw > remaining || nbf > remaining ||
            nsplits > remaining) {
            return corrupt(16, "counts larger than the file");
        }
        position_alive_.assign(pm.position_count, 0);
        wedge_alive_.assign(pm.wedge_count, 0);
        wedge_position_.assign(pm.wedge_count, 0);
        face_alive_.assign(pm.face_count, 0);

        pm.base_positions.resize(nbp);
        for (PmVertex& v : pm.base_positions) {
            if (Status s = new_position(pm, v); !s) return s.error();
        }
        pm.base_wedges.resize(nbw);
        for (PmWedge& w : pm.base_wedges) {
            const size_t at = r_.offset();
            uint32_t id;
            if (!r_.u32(id) || !r_.u32(w.position)) return truncated();
            if (w.position >= pm.position_count || !position_alive_[w.position]) {
                return corrupt(at + 4, "wedge of a position not in the mesh");
            }
            if (Status s = new_wedge(pm, w, id, w.position, at); !s) return s.error();
        }
        pm.base_faces.resize(nbf);
        for (PmFace& f : pm.base_faces) {
            if (Status s = new_face(pm, f); !s) return s.error();
        }
        pm.splits.resize(nsplits);
        for (VertexSplit& s : pm.splits) {
            const size_t at = r_.offset();
            if (Status st = new_position(pm, s.removed); !st) return st.error();
            if (!r_.u32(s.kept)) return truncated();
            if (s.kept >= pm.position_count || !position_alive_[s.kept] || s.kept == s.removed.id) {
                return corrupt(at + 16, "split of a position not in the mesh");
            }
            if (!vec3(s.kept_position)) return truncated();
            uint32_t nrw, nkw, nf, nc;
            if (!r_.u32(nrw) || !r_.u32(nkw) || !r_.u32(nf) || !r_.u32(nc)) return truncated();
            const size_t left = r_.size() - r_.offset();
            if (nrw > left || nkw > left || nf > left || nc > left) {
                return corrupt(r_.offset() - 16, "split counts larger than the file");
            }
            s.removed_wedges.resize(nrw);
            for (PmWedge& w : s.removed_wedges) {
                const size_t wat = r_.offset();
                uint32_t id;
                if (!r_.u32(id)) return truncated();
                if (Status st = new_wedge(pm, w, id, s.removed.id, wat); !st) return st.error();
            }
            s.kept_wedges.resize(nkw);
            for (PmWedge& w : s.kept_wedges) {
                const size_t wat = r_.offset();
                if (!r_.u32(w.id)) return truncated();
                if (w.id >= pm.wedge_count || !wedge_alive_[w.id] ||
                    wedge_position_[w.id] != s.kept) {
                    return corrupt(wat, "wedge " + std::to_string(w.id) +
                                            " is not a wedge of the split position");
                }
                w.position = s.kept;
                if (!attributes(pm, w)) return truncated();
            }
            s.faces.resize(nf);
            for (PmFace& f : s.faces) {
                if (Status st = new_face(pm, f); !st) return st.error();
            }
            s.corners.resize(nc);
            for (PmCorner& c : s.corners) {
                const size_t cat = r_.offset();
                if (!r_.u32(c.corner) || !r_.u32(c.wedge)) return truncated();
                if (c.corner / 3 >= pm.face_count || !face_alive_[c.corner / 3]) {
                    return corrupt(cat, "corner of a face not in the mesh");
                }
                if (c.wedge >= pm.wedge_count || !wedge_alive_[c.wedge] ||
                    wedge_position_[c.wedge] != s.removed.id) {
                    return corrupt(cat + 4, "corner wedge not of the split position");
                }
            }
        }
        if (!r_.at_end()) return corrupt(r_.offset(), "trailing bytes after the last split");
        return pm;
    }

  private:
    Error truncated() const { return corrupt(r_.offset(), "truncated"); }
    bool vec3(glm::vec3& v) { return r_.f32(v.x) && r_.f32(v.y) && r_.f32(v.z); }
    bool attributes(const ProgressiveMesh& pm, PmWedge& w) {
        bool ok = true;
        if (pm.has_normals) ok = ok && vec3(w.normal);
        if (pm.has_uv0) ok = ok && r_.f32(w.uv0.x) && r_.f32(w.uv0.y);
        if (pm.has_uv1) ok = ok && r_.f32(w.uv1.x) && r_.f32(w.uv1.y);
        if (pm.has_colors) {
            ok = ok && r_.f32(w.color.x) && r_.f32(w.color.y) && r_.f32(w.color.z) &&
                 r_.f32(w.color.w);
        }
        return ok;
    }
    Status new_position(const ProgressiveMesh& pm, PmVertex& v) {
        const size_t at = r_.offset();
        if (!r_.u32(v.id)) return truncated();
        if (v.id >= pm.position_count) {
            return corrupt(at, "position id " + std::to_string(v.id) + " out of range");
        }
        if (position_alive_[v.id]) {
            return corrupt(at, "position " + std::to_string(v.id) + " added twice");
        }
        if (!vec3(v.position)) return truncated();
        if (!std::isfinite(v.position.x) || !std::isfinite(v.position.y) ||
            !std::isfinite(v.position.z)) {
            return corrupt(at + 4, "position is not finite");
        }
        position_alive_[v.id] = 1;
        return Status::success();
    }
    Status new_wedge(const ProgressiveMesh& pm, PmWedge& w, uint32_t id, uint32_t position,
                     size_t at) {
        if (id >= pm.wedge_count) {
            return corrupt(at, "wedge id " + std::to_string(id) + " out of range");
        }
        if (wedge_alive_[id]) return corrupt(at, "wedge " + std::to_string(id) + " added twice");
        w.id = id;
        w.position = position;
        if (!attributes(pm, w)) return truncated();
        wedge_alive_[id] = 1;
        wedge_position_[id] = position;
        return Status::success();
    }
    Status new_face(const ProgressiveMesh& pm, PmFace& f) {
        const size_t at = r_.offset();
        if (!r_.u32(f.id)) return truncated();
        if (f.id >= pm.face_count) {
            return corrupt(at, "face id " + std::to_string(f.id) + " out of range");
        }
        if (face_alive_[f.id]) return corrupt(at, "face " + std::to_string(f.id) + " added twice");
        for (int k = 0; k < 3; ++k) {
            const size_t wat = r_.offset();
            if (!r_.u32(f.wedges[k])) return truncated();
            if (f.wedges[k] >= pm.wedge_count || !wedge_alive_[f.wedges[k]]) {
                return corrupt(wat, "face corner refers to a wedge not in the mesh");
            }
        }
        face_alive_[f.id] = 1;
        return Status::success();
    }

    Reader r_;
    std::vector<uint8_t> position_alive_, wedge_alive_, face_alive_;
    std::vector<uint32_t> wedge_position_;
};

}  // namespace

std::vector<uint8_t> encode_progressive_mesh(const ProgressiveMesh& pm) {
    Writer w;
    for (char c : kMagic) w.bytes.push_back(uint8_t(c));
    w.u32(kVersion);
    w.u32(uint32_t(pm.has_normals) | uint32_t(pm.has_uv0) << 1 | uint32_t(pm.has_uv1) << 2 |
          uint32_t(pm.has_colors) << 3);
    w.u32(uint32_t(int32_t(pm.material)));
    w.u32(pm.position_count);
    w.u32(pm.wedge_count);
    w.u32(pm.face_count);
    w.u32(uint32_t(pm.base_positions.size()));
    w.u32(uint32_t(pm.base_wedges.size()));
    w.u32(uint32_t(pm.base_faces.size()));
    w.u32(uint32_t(pm.splits.size()));
    auto face = [&w](const PmFace& f) {
        w.u32(f.id);
        for (uint32_t x : f.wedges) w.u32(x);
    };
    for (const PmVertex& v : pm.base_positions) w.u32(v.id), w.vec(&v.position.x, 3);
    for (const PmWedge& x : pm.base_wedges) {
        w.u32(x.id), w.u32(x.position);
        write_attributes(w, pm, x);
    }
    for (const PmFace& f : pm.base_faces) face(f);
    for (const VertexSplit& s : pm.splits) {
        w.u32(s.removed.id), w.vec(&s.removed.position.x, 3);
        w.u32(s.kept), w.vec(&s.kept_position.x, 3);
        w.u32(uint32_t(s.removed_wedges.size()));
        w.u32(uint32_t(s.kept_wedges.size()));
        w.u32(uint32_t(s.faces.size()));
        w.u32(uint32_t(s.corners.size()));
        for (const PmWedge& x : s.removed_wedges) w.u32(x.id), write_attributes(w, pm, x);
        for (const PmWedge& x : s.kept_wedges) w.u32(x.id), write_attributes(w, pm, x);
        for (const PmFace& f : s.faces) face(f);
        for (const PmCorner& c : s.corners) w.u32(c.corner), w.u32(c.wedge);
    }
    return std::move(w.bytes);
}

Result<ProgressiveMesh> decode_progressive_mesh(std::span<const uint8_t> bytes) {
    return Decoder(bytes).decode();
}

Status write_progressive_mesh(const std::filesystem::path& path, const ProgressiveMesh& pm) {
    const std::vector<uint8_t> bytes = encode_progressive_mesh(pm);
    return write_file_atomically(
        path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

Result<ProgressiveMesh> read_progressive_mesh(const std::filesystem::path& path) {
    Result<std::string> bytes = read_file(path);
    if (!bytes) return bytes.error();
    Result<ProgressiveMesh> pm = decode_progressive_mesh(
        std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(bytes->data()), bytes->size()));
    if (!pm) return make_error(path.string() + ": " + pm.error().message);
    return pm;
}

}  // namespace hmdnode
