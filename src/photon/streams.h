#pragma once
// Photon streams (docs/design.md, Photon emission and streams): the light paths of every light
// are partitioned by where their first segment goes. Targets are bounding spheres, in order: the
// specular surfaces (caustics), the media, and the ground around the media (the "near" sphere,
// three times the media's radius: where light bounces into them). Stream (light, k) holds the paths
// whose first segment meets target k and no earlier target; the last stream of a light, the rest,
// holds those that meet none. Every path belongs to exactly one stream, so the sum over streams is
// unbiased whatever each stream's photon count; within a stream every photon carries the same
// power, (power of the region it samples) / (its attempts).
// A stream samples its region directly — sun and sky: origins on the target's disc across the
// light's direction; point and spot lights: directions in the cone the target subtends — and an
// attempt whose path belongs to an earlier stream (or that a spot's falloff rejects) yields no
// photon.
// One more stream when the scene has media, diffuse surfaces and a sun or sky: the bounce stream,
// which holds the sun's and sky's paths whose first interaction is a diffuse surface y and whose
// next segment crosses the media target's disc across it (no surface between): from a wide
// ground those reach the media as rare photons of great power in the lights' streams. It samples
// lines through the media sphere uniformly (a direction, a point of the disc across it), finds
// the surface y behind the disc point and starts a photon there with the sun's and sky's direct
// light y reflects along the line (one shadow ray each), so the ground's light reaches the media
// through photons of comparable power. It stores volume photons only; the lights' streams keep
// everything else (and all of a point, spot or quad light's paths, whose light falls near them).
// Each emitting medium has one stream more, not partitioned: photons leave points drawn ∝ its
// σ_a L_e (Medium::Sampler::sample_emission) in uniform directions.
// Why: a stream aimed at a small target (the media, a glass ball) gets photons there without
// tracing the light's other paths, and the photon pass can give each stream its own count.
// Immutable after make_streams; thread-safe.

#include "core/rng.h"
#include "media/medium.h"
#include "scene/scene.h"

#include <cstdint>
#include <string>
#include <vector>

namespace fogmap {

/// A bounding sphere streams aim the first segment of their paths at.
struct StreamTarget {
    Vec3 center{0.0f};
    float radius = 0.0f;
    std::string name;  ///< "specular", "media", "near media"
};

struct PhotonStream {
    int light = 0;    ///< index into Scene::lights; -1 for the bounce and emission streams
    int medium = -1;  ///< emission streams: index into Scene::media
    int target = -1;  ///< index into StreamSet::targets; -1: the rest of the light's paths
    double region_power = 0.0;  ///< W (channel average) of the region one attempt samples
    Color color{1.0f};          ///< the light's power per channel / its channel average
    uint64_t key = 0;           ///< the stream's random-number stream
    std::string name;           ///< "sun 0 → media", for reports
};

struct StreamSet {
    std::vector<StreamTarget> targets;
    std::vector<PhotonStream> streams;
    int bounce = -1;  ///< index of the bounce stream in streams, -1 if none
    /// The bounce stream's target (the media): whether a light path's segment leaving its first,
    /// diffuse, interaction belongs to the bounce stream.
    bool owns_bounce(const Scene& scene, const Ray& ray) const;
};

/// The streams of `scene`'s lights that emit, with targets for the specular surfaces (when
/// `specular`), the media and their surroundings (when `media`); lights without power get none.
/// A target-k stream that no path can belong to (the light sits inside an earlier target, or
/// target k lies within an earlier one) is left out.
StreamSet make_streams(const Scene& scene, bool specular, bool media);

/// One attempt of stream `s`: true and the photon's ray (unit direction), or false when the
/// attempt's path belongs to another stream or a spot's falloff rejected it. Draws only from rng.
bool sample_stream(const StreamSet& set, int s, const Scene& scene, Rng& rng, Ray* ray);

/// One attempt of the bounce stream `s`: true, the photon's ray (unit direction, leaving a
/// diffuse surface) and its relative power, or false when the line meets no diffuse surface
/// behind the disc or that surface receives no direct light. Draws only from rng; `media` are this
/// thread's samplers (for the shadow rays).
bool sample_bounce(const StreamSet& set, int s, const Scene& scene,
                   std::vector<Medium::Sampler>& media, Rng& rng, Ray* ray, Color* power);

/// One attempt of emission stream `s`: true, the photon's ray (from a point of the medium, uniform
/// direction) and its relative power (colour, channel average 1), or false when the medium's
/// emission sampling rejected the point. Draws only from rng; `media` are this thread's samplers.
bool sample_emission_stream(const StreamSet& set, int s, std::vector<Medium::Sampler>& media,
                            Rng& rng, Ray* ray, Color* power);

/// True if the ray (unit direction, t > 0) meets the sphere.
bool meets_sphere(const Ray& ray, const Vec3& center, float radius);

}  // namespace fogmap
