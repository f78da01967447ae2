#include "photon/streams.h"

#include "core/rng.h"
#include "core/sampling.h"
#include "scene/shadow.h"

#include <algorithm>
#include <cmath>

namespace fogmap {

namespace {

constexpr float kNearFactor = 3.0f;  // the "near media" sphere: 3 × the media's radius

StreamTarget sphere_of(const Box3& b, const std::string& name) {
    return {b.center(), 0.5f * glm::length(b.extent()), name};
}

bool is_infinite(const Light& l) {
    return l.type == LightType::Sun || l.type == LightType::Environment;
}

float smoothstep(float a, float b, float x) {
    if (b <= a) return x >= b ? 1.0f : 0.0f;
    const float t = std::clamp((x - a) / (b - a), 0.0f, 1.0f);
    return t * t * (3.0f - 2.0f * t);
}

/// A direction uniform in the cone of half-angle acos(cos_max) about unit `axis`.
Vec3 sample_cone(const Vec3& axis, float cos_max, Vec2 u) {
    const float cos_t = 1.0f - u.x * (1.0f - cos_max);
    const float sin_t = std::sqrt(std::max(0.0f, 1.0f - cos_t * cos_t));
    const float phi = kTwoPi * u.y;
    return glm::normalize(
        to_world(Vec3(sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t), axis));
}

/// Cosine of the half-angle of the cone from p that holds sphere (c, r); -1 when p is inside.
float cone_cos(const Vec3& p, const StreamTarget& t) {
    const float d = glm::length(t.center - p);
    if (d <= t.radius) return -1.0f;
    const float s = t.radius / d;
    return std::sqrt(std::max(0.0f, 1.0f - s * s));
}

bool inside(const Vec3& p, const StreamTarget& t) { return glm::length(t.center - p) <= t.radius; }

bool sphere_within(const StreamTarget& a, const StreamTarget& b) {  // a inside b
    return glm::length(a.center - b.center) + a.radius <= b.radius;
}

/// The bounce stream (streams.h), when the scene has media, a diffuse surface and a sun or sky.
/// Its region power is 4π · π R² · L_ref, L_ref a scale of the radiance a lit diffuse surface
/// reflects (the sun's and sky's irradiance × the largest albedo / π); each photon carries its
/// own radiance / L_ref, so the scale only balances the allocation between streams. `media`: the
/// media target's index (-1: none).
void add_bounce_stream(const Scene& scene, int media, StreamSet* set) {
    if (media < 0 || set->streams.empty() || !scene.surfaces) return;
    float albedo = 0.0f;
    for (const Material& m : scene.materials)
        if (!m.is_specular()) albedo = std::max(albedo, average(m.albedo));
    const StreamTarget& t = set->targets[media];
    double irradiance = 0.0;
    for (const Light& l : scene.lights)
        irradiance += l.type == LightType::Sun           ? average(l.irradiance)
                      : l.type == LightType::Environment ? kPi * average(l.radiance)
                                                         : 0.0;
    const double radiance = irradiance * albedo * kInvPi;
    if (!(radiance > 0.0)) return;
    PhotonStream s;
    s.light = -1;
    s.target = media;
    s.region_power = 4.0 * kPi * kPi * double(t.radius) * t.radius * radiance;
    s.key = mix64(stream::kPhotonBounce);
    s.name = "diffuse bounce → media";
    set->bounce = static_cast<int>(set->streams.size());
    set->streams.push_back(s);
}

/// Where a line along unit d crosses the disc across d through the target's centre: the distance
/// from o along d, or -1 when it passes outside the disc or the disc lies behind o.
float disc_distance(const Vec3& o, const Vec3& d, const StreamTarget& t) {
    const DVec3 oc = DVec3(t.center) - DVec3(o), dd = DVec3(d);
    const double along = glm::dot(oc, dd);
    const DVec3 perp = oc - along * dd;
    return along > 0.0 && glm::dot(perp, perp) < double(t.radius) * t.radius ? float(along) : -1.0f;
}

}  // namespace

bool StreamSet::owns_bounce(const Scene& scene, const Ray& ray) const {
    if (bounce < 0) return false;
    const float t = disc_distance(ray.o, ray.d, targets[streams[bounce].target]);
    if (t < 0.0f) return false;
    return !scene.surfaces->occluded(ray, 0.0f, t);
}

bool sample_bounce(const StreamSet& set, int s, const Scene& scene,
                   std::vector<Medium::Sampler>& media, Rng& rng, Ray* ray, Color* power) {
    const PhotonStream& st = set.streams[s];
    const StreamTarget& t = set.targets[st.target];
    const Vec2 u(rng.uniform(), rng.uniform()), v(rng.uniform(), rng.uniform());
    const Vec3 d = sample_uniform_sphere(u);
    const float rad = t.radius * std::sqrt(v.x), phi = kTwoPi * v.y;
    const Vec3 p = t.center + to_world(Vec3(rad * std::cos(phi), rad * std::sin(phi), 0.0f), d);
    const std::optional<SurfaceHit> hit = scene.surfaces->intersect(Ray{p, -d}, 0.0f, kInfinity);
    if (!hit || hit->material < 0) return false;
    const Material& m = scene.materials[hit->material];
    if (m.is_specular()) return false;
    const Vec3 n = glm::dot(d, hit->ng) > 0.0f ? hit->ng : -hit->ng;  // the side it leaves from
    uint64_t rays = 0;
    const Color L = direct_diffuse(scene, media, hit->p, n, m.albedo, rng, &rays, true);
    if (!(max_component(L) > 0.0f)) return false;
    const double scale = st.region_power / (4.0 * kPi * kPi * double(t.radius) * t.radius);
    *ray = Ray{offset_point(hit->p, n, scene.offset_floor), d};
    *power = L / static_cast<float>(scale);
    return true;
}

// The distance from the centre to the line is taken from the perpendicular vector, not as
// |oc|² − along²: rays start outside the scene's sphere, kilometres away over a 10 km ground, and
// there that difference of two ~10⁷ floats kept nothing of a 1 m target's r² ≈ 3. Streams then
// took paths that belonged to the media stream as their own: the cloud in the photon maps came
// out 15% too bright.
bool meets_sphere(const Ray& ray, const Vec3& center, float radius) {
    const DVec3 oc = DVec3(center) - DVec3(ray.o), d = DVec3(ray.d);
    const double along = glm::dot(oc, d), r2 = double(radius) * radius;
    if (glm::dot(oc, oc) <= r2) return true;  // starts inside
    const DVec3 perp = oc - along * d;
    return along > 0.0 && glm::dot(perp, perp) < r2;
}

namespace {

/// The targets (streams.h): the specular surfaces' sphere when `specular`, the media's and the
/// "near media" sphere around it when `media`. Returns the media target's index (-1: none).
int add_targets(const Scene& scene, bool specular, bool media, StreamSet* set) {
    if (specular && scene.surfaces) {
        Box3 b;
        for (const Mesh& m : scene.surfaces->meshes())
            if (m.material >= 0 && scene.materials[m.material].is_specular())
                for (const Vec3& p : m.positions) b.extend(p);
        for (const Sphere& s : scene.surfaces->spheres())
            if (s.material >= 0 && scene.materials[s.material].is_specular()) {
                b.extend(s.center - Vec3(s.radius));
                b.extend(s.center + Vec3(s.radius));
            }
        if (!b.empty()) set->targets.push_back(sphere_of(b, "specular"));
    }
    if (!media) return -1;
    Box3 b;
    for (const Medium& m : scene.media) b.extend(m.world_bounds());
    if (b.empty()) return -1;
    const int media_target = static_cast<int>(set->targets.size());
    set->targets.push_back(sphere_of(b, "media"));
    StreamTarget near = set->targets.back();
    near.radius *= kNearFactor;
    near.name = "near media";
    set->targets.push_back(near);
    return media_target;
}

/// The streams of light `li` (one per target its paths can meet first, then the rest; a quad
/// light's one), none when it has no power. `world`: the scene's bounding sphere.
void add_light_streams(const Scene& scene, size_t li, const StreamTarget& world, StreamSet* set) {
    const Light& l = scene.lights[li];
    const Color power = light_power(l, scene.bounds);
    const double avg = average(power);
    if (!(avg > 0.0)) return;
    const std::string light_name = std::string(to_string(l.type)) + " " + std::to_string(li);
    auto add = [&](int target, double region_power) {
        PhotonStream s;
        s.light = static_cast<int>(li);
        s.target = target;
        s.region_power = region_power;
        s.color = power / static_cast<float>(avg);
        s.key = mix64(stream::kPhotonLight + li * 0x100 + static_cast<uint64_t>(target + 1));
        s.name = light_name + " → " + (target < 0 ? "rest" : set->targets[target].name);
        set->streams.push_back(s);
    };
    if (l.type == LightType::Quad) {  // one stream: its paths are not partitioned
        add(-1, avg);
        return;
    }
    // Power of the light through the region a stream samples: a disc of radius r across the
    // light's direction (sun: E π r²; sky: L 4π · π r²), or a cone of solid angle Ω from the
    // light (I Ω), the spot's cone at most.
    auto disc_power = [&](float r) {
        const double area = kPi * double(r) * r;
        return l.type == LightType::Sun ? average(l.irradiance) * area
                                        : average(l.radiance) * 4.0 * kPi * area;
    };
    const bool spot = l.type == LightType::Spot;
    const float whole = spot ? l.cos_outer : -1.0f;  // the cone all of the light's paths fill
    auto cone_power = [&](float cos_max) {
        return average(l.intensity) * kTwoPi * (1.0 - double(cos_max));
    };
    const std::vector<StreamTarget>& targets = set->targets;
    bool covered = false;  // every path of this light already belongs to a target stream
    for (size_t k = 0; k < targets.size() && !covered; ++k) {
        const StreamTarget& t = targets[k];
        bool within_earlier = false;
        for (size_t j = 0; j < k; ++j) within_earlier |= sphere_within(t, targets[j]);
        if (within_earlier) continue;
        if (is_infinite(l)) {
            add(static_cast<int>(k), disc_power(t.radius));
            continue;
        }
        bool in_earlier = false;
        for (size_t j = 0; j < k; ++j) in_earlier |= inside(l.position, targets[j]);
        if (in_earlier) break;
        if (inside(l.position, t)) {
            add(static_cast<int>(k), cone_power(whole));
            covered = true;
            continue;
        }
        if (spot) {  // a target cone outside the spot's cone receives nothing
            const Vec3 to = glm::normalize(t.center - l.position);
            const float angle = std::acos(std::clamp(glm::dot(to, l.direction), -1.0f, 1.0f));
            if (angle - std::acos(cone_cos(l.position, t)) > std::acos(l.cos_outer)) continue;
        }
        add(static_cast<int>(k), cone_power(cone_cos(l.position, t)));
    }
    bool in_any = false;
    for (const StreamTarget& t : targets) in_any |= !is_infinite(l) && inside(l.position, t);
    if (covered || in_any) return;
    add(-1, is_infinite(l) ? disc_power(world.radius) : cone_power(whole));
}

/// One stream per emitting medium (streams.h), after the lights' and the bounce stream.
void add_emission_streams(const Scene& scene, StreamSet* set) {
    for (size_t i = 0; i < scene.media.size(); ++i) {
        const double power = scene.media[i].emission_bound_power();
        if (!(power > 0.0)) continue;
        PhotonStream s;
        s.light = -1;
        s.medium = static_cast<int>(i);
        s.region_power = power;
        s.key = mix64(stream::kPhotonEmission * 0x100 + i);
        s.name = "medium " + std::to_string(i) + " emission";
        set->streams.push_back(s);
    }
}

}  // namespace

StreamSet make_streams(const Scene& scene, bool specular, bool media) {
    StreamSet set;
    const int media_target = add_targets(scene, specular, media, &set);
    const StreamTarget world = sphere_of(scene.bounds, "scene");
    for (size_t li = 0; li < scene.lights.size(); ++li) add_light_streams(scene, li, world, &set);
    add_bounce_stream(scene, media_target, &set);
    add_emission_streams(scene, &set);
    return set;
}

bool sample_emission_stream(const StreamSet& set, int s, std::vector<Medium::Sampler>& media,
                            Rng& rng, Ray* ray, Color* power) {
    Vec3 x;
    if (!media[set.streams[s].medium].sample_emission(rng, &x, power)) return false;
    *ray = Ray{x, sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform()))};
    return true;
}

bool sample_stream(const StreamSet& set, int s, const Scene& scene, Rng& rng, Ray* ray) {
    const PhotonStream& st = set.streams[s];
    const Light& l = scene.lights[st.light];
    const Vec2 u(rng.uniform(), rng.uniform());
    const Vec2 v(rng.uniform(), rng.uniform());
    if (l.type == LightType::Quad) {
        *ray =
            Ray{l.corner + u.x * l.edge_u + u.y * l.edge_v, sample_cosine_hemisphere(l.normal, v)};
        return true;
    }
    // Earlier targets (all of them for the rest) whose paths belong to other streams.
    const size_t earlier = st.target < 0 ? set.targets.size() : static_cast<size_t>(st.target);
    if (is_infinite(l)) {
        Vec3 d;
        if (l.type == LightType::Environment)
            d = sample_uniform_sphere(u);
        else if (l.sun_one_minus_cos > 0.0f)
            d = -sample_light(l, Vec3(0.0f), u).wi;
        else
            d = l.direction;
        const StreamTarget world{scene.bounds.center(), 0.5f * glm::length(scene.bounds.extent()),
                                 ""};
        const StreamTarget& disc = st.target < 0 ? world : set.targets[st.target];
        // A point of the disc across d through the target's centre, moved back along −d to
        // outside the scene's sphere (so nothing between the scene's edge and the target is
        // skipped).
        const float rad = disc.radius * std::sqrt(v.x), phi = kTwoPi * v.y;
        const float back = 1.01f * (world.radius + glm::length(disc.center - world.center));
        *ray = Ray{disc.center + to_world(Vec3(rad * std::cos(phi), rad * std::sin(phi), 0.0f), d) -
                       back * d,
                   d};
    } else {
        Vec3 axis = l.type == LightType::Spot ? l.direction : Vec3(0.0f, 0.0f, 1.0f);
        float cos_max = l.type == LightType::Spot ? l.cos_outer : -1.0f;
        if (st.target >= 0) {  // outside the target: its cone; inside: the whole light
            const StreamTarget& t = set.targets[st.target];
            const float c = cone_cos(l.position, t);
            if (c > -1.0f) {
                axis = glm::normalize(t.center - l.position);
                cos_max = c;
            }
        }
        const Vec3 d = sample_cone(axis, cos_max, u);
        if (l.type == LightType::Spot &&
            v.x >= smoothstep(l.cos_outer, l.cos_inner, glm::dot(d, l.direction)))
            return false;  // the falloff, by rejection: every photon carries the same power
        *ray = Ray{l.position, d};
    }
    for (size_t j = 0; j < earlier; ++j)
        if (meets_sphere(*ray, set.targets[j].center, set.targets[j].radius)) return false;
    return true;
}

}  // namespace fogmap
