#pragma once
// Photon streams (DESIGN.md, Next: photon streams): the light paths of every light are partitioned
// by where their first segment goes. Targets are bounding spheres, in order: the specular
// surfaces (caustics), the media, and the ground around the media (the "near" sphere, three times
// the media's radius: where light bounces into them). Stream (light, k) holds the paths whose
// first segment meets target k and no earlier target; the last stream of a light, the rest, holds
// those that meet none. Every path belongs to exactly one stream, so the sum over streams is
// unbiased whatever each stream's photon count; within a stream every photon carries the same
// power, (power of the region it samples) / (its attempts).
// A stream samples its region directly — sun and sky: origins on the target's disc across the
// light's direction; point and spot lights: directions in the cone the target subtends — and an
// attempt whose path belongs to an earlier stream (or that a spot's falloff rejects) yields no
// photon. Immutable after make_streams; thread-safe.

#include "core/rng.h"
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
    int light = 0;    ///< index into Scene::lights
    int target = -1;  ///< index into StreamSet::targets; -1: the rest of the light's paths
    double region_power = 0.0;  ///< W (channel average) of the region one attempt samples
    Color color{1.0f};          ///< the light's power per channel / its channel average
    uint64_t key = 0;           ///< the stream's random-number stream
    std::string name;           ///< "sun 0 → media", for reports
};

struct StreamSet {
    std::vector<StreamTarget> targets;
    std::vector<PhotonStream> streams;
};

/// The streams of `scene`'s lights that emit, with targets for the specular surfaces (when
/// `specular`), the media and their surroundings (when `media`); lights without power get none.
/// A target-k stream that no path can belong to (the light sits inside an earlier target, or
/// target k lies within an earlier one) is left out.
StreamSet make_streams(const Scene& scene, bool specular, bool media);

/// One attempt of stream `s`: true and the photon's ray (unit direction), or false when the
/// attempt's path belongs to another stream or a spot's falloff rejected it. Draws only from rng.
bool sample_stream(const StreamSet& set, int s, const Scene& scene, Rng& rng, Ray* ray);

/// True if the ray (unit direction, t > 0) meets the sphere.
bool meets_sphere(const Ray& ray, const Vec3& center, float radius);

}  // namespace fogmap
