#pragma once
// The photon pass (DESIGN.md, Photons): photons leave the lights in proportion to their power,
// all carrying the same power; Russian roulette on albedo decides survival at every interaction;
// free paths in media by ray marching (default) or delta tracking. Storage: global map at
// diffuse hits after at least one interaction, caustic map for L S+ D, volume map at scattering
// events after at least one interaction (the first interaction from a light is left to shadow
// rays). Shooting goes on until each map holds its budget or photons.max_emitted have left.
// Deterministic: photon i draws from Rng(seed, i, kPhotonStream) and batches merge in index order.

#include "photon/kd_tree.h"
#include "photon/photon.h"
#include "scene/plan.h"
#include "scene/scene.h"

#include <optional>
#include <string>
#include <vector>

namespace fogmap {

/// One map's photons before its tree is built.
struct StoredPhotons {
    std::vector<Photon> photons;
    uint64_t budget = 0;
    uint64_t emitted = 0;  ///< photons emitted when the map filled (its power divides by this)
};

struct PhotonPassResult {
    std::optional<StoredPhotons> global, caustic, volume;  ///< absent when the Plan leaves it out
    uint64_t emitted = 0;                                  ///< photons emitted in all
    float total_power = 0.0f;  ///< Σ over lights of the channel-average power (W)
    double time_s = 0.0;
    std::vector<std::string> warnings;
};

/// Runs the photon pass for the maps the plan turns on. Progress on stderr unless quiet.
PhotonPassResult trace_photons(const Scene& scene, const Plan& plan, bool quiet);

/// A built map: its kd-tree and the world power of a photon whose relative power is 1.
struct PhotonMap {
    KdTree<Photon> tree;
    float photon_power = 0.0f;  ///< W per photon (total power / emitted)
    uint64_t emitted = 0;
    double build_s = 0.0;
};

struct PhotonMaps {
    std::optional<PhotonMap> global, caustic, volume;
};

/// Builds one balanced kd-tree per map (the maps in parallel); consumes the pass result.
PhotonMaps build_trees(PhotonPassResult&& pass);

}  // namespace fogmap
