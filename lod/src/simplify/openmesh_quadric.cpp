// "openmesh-quadric": OpenMesh's own Decimater with ModQuadric, the baseline the benchmark
// compares our simplifiers with.
//
// Paper: M. Garland, P. Heckbert, "Surface simplification using quadric error metrics",
// SIGGRAPH 1997, as implemented by OpenMesh (Tools/Decimater/ModQuadricT): half-edge collapses
// (the survivor stays where it is, no optimal placement) ordered by the quadric error of the
// removed vertex at the survivor, with ModNormalFlippingT rejecting collapses that turn a face
// normal by more than 90 degrees.
//
// Departure: a binary module of ours (ModWedgeT) adds the seam and border rules of
// openmesh_mesh.hpp (a seam vertex only collapses along its seam, borders kept or locked) and
// carries the per-corner attributes through each collapse, so that the output has valid UVs like
// every other entry. Levels are made one after the other on the same mesh
// (decimate_to_faces(0, target)).
//
// Cost: O(n log n) (OpenMesh's heap), each collapse O(valence^2); memory O(V + T) plus
// OpenMesh's quadric per vertex.
#include <OpenMesh/Tools/Decimater/DecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModBaseT.hh>
#include <OpenMesh/Tools/Decimater/ModNormalFlippingT.hh>
#include <OpenMesh/Tools/Decimater/ModQuadricT.hh>

#include "algorithms.hpp"
#include "openmesh_mesh.hpp"

namespace hmdnode::lod_detail {
namespace {

template <class MeshT>
class ModWedgeT : public OpenMesh::Decimater::ModBaseT<MeshT> {
  public:
    DECIMATING_MODULE(ModWedgeT, MeshT, Wedge);

    explicit ModWedgeT(MeshT& mesh) : Base(mesh, true) {}

    void bind(WeldedMesh* welded, const CollapseRules& rules) {
        welded_ = welded;
        rules_ = rules;
    }
    float collapse_priority(const CollapseInfo& ci) override {
        CollapsePlan plan;
        return plan_collapse(*welded_, ci.v0v1, nullptr, rules_, &plan)
                   ? float(Base::LEGAL_COLLAPSE)
                   : float(Base::ILLEGAL_COLLAPSE);
    }
    void preprocess_collapse(const CollapseInfo& ci) override {
        // note: the Decimater's heap entry may be stale (it re-checks topology only).
        if (!plan_collapse(*welded_, ci.v0v1, nullptr, rules_, &plan_))
            plan_ = forced_plan(*welded_, ci.v0v1);
        prepare_collapse(*welded_, plan_);
    }
    void postprocess_collapse(const CollapseInfo&) override { finish_collapse(*welded_, plan_); }

  private:
    WeldedMesh* welded_ = nullptr;
    CollapseRules rules_;
    CollapsePlan plan_;
};

}  // namespace

Result<std::vector<SimplifiedLevel>> simplify_openmesh_quadric(const Primitive& in,
                                                               std::span<const size_t> targets,
                                                               const SimplifyOptions& options) {
    WeldedMesh m = weld_to_openmesh(in, options.locked_positions);
    CollapseRules rules;
    rules.lock_borders = options.lock_borders;
    // note: our own flip rule would also reject what ModNormalFlipping does; keep OpenMesh's.
    rules.min_normal_cos = -2.0;    // note: disables our flip rules, keeps the sliver rule
    m.mesh.request_face_normals();  // for ModNormalFlipping (else it says it computes them)
    m.mesh.update_face_normals();
    OpenMesh::Decimater::DecimaterT<OmMesh> decimater(m.mesh);
    OpenMesh::Decimater::ModQuadricT<OmMesh>::Handle quadric;
    OpenMesh::Decimater::ModNormalFlippingT<OmMesh>::Handle flipping;
    ModWedgeT<OmMesh>::Handle wedge;
    decimater.add(quadric);
    decimater.add(flipping);
    decimater.add(wedge);
    decimater.module(quadric).unset_max_err();
    decimater.module(wedge).bind(&m, rules);
    if (!decimater.initialize())
        return make_error("openmesh-quadric: Decimater did not initialise");
    std::vector<SimplifiedLevel> levels;
    for (size_t i = 0; i < targets.size(); ++i) {
        // note: the Decimater counts from mesh.n_faces(), which includes the faces deleted by
        // the previous levels (no garbage collection, so that our face indices stay valid).
        const size_t deleted = m.mesh.n_faces() - m.alive_faces;
        decimater.decimate_to_faces(0, targets[i] + deleted);
        levels.push_back({to_primitive(m), -1.0});
        if (options.progress) options.progress(double(i + 1) / double(targets.size()));
    }
    return levels;
}

}  // namespace hmdnode::lod_detail
