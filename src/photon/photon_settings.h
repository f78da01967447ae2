#pragma once
// The photon pass's budgets as a run resolves them (render/run_setup.h, resolve_run): the
// scene's "photons" keys with the rules applied, and what the chosen method adds.

#include "scene/scene_desc.h"

#include <cstdint>

namespace fogmap {

/// Where camera paths end in the volume map: photon attempts per camera sample at which the
/// volume map closes (photon/photon_pass.h).
inline constexpr double kVolumeAttemptsPerSample = 0.25;

struct PhotonSettings {
    uint64_t global = PhotonDesc{}.global;    ///< stored photons; 0 = map not built
    uint64_t caustic = PhotonDesc{}.caustic;  ///< stored photons; 0 = map not built
    uint64_t volume = kDefaultVolumePhotons;  ///< stored photons; 0 = map not built
    uint64_t max_emitted = 0;                 ///< cap on emitted photons; 0 = 100 x the largest
    int max_bounces = PhotonDesc{}.max_bounces;
    /// The volume map keeps its paths' beams too (the photon beams estimate).
    bool volume_beams = false;
    /// With the volume map the only map, it closes after this many attempts (0 = no such rule).
    uint64_t volume_attempts = 0;

    PhotonSettings() = default;
    /// The scene's keys as given, no rule applied (tests and benchmarks that trace one pass).
    PhotonSettings(const PhotonDesc& d)  // NOLINT(google-explicit-constructor): keys → budgets
        : global(d.global),
          caustic(d.caustic),
          volume(d.volume_or_default()),
          max_emitted(d.max_emitted),
          max_bounces(d.max_bounces) {}
};

}  // namespace fogmap
