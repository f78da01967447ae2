#include "render/path_tracer.h"

#include "core/error.h"
#include "core/sampling.h"
#include "media/phase.h"
#include "render/camera.h"
#include "scene/shadow.h"

#include <algorithm>
#include <array>
#include <optional>

namespace fogmap {

namespace {

float power_heuristic(float a, float b) {
    const float a2 = a * a, b2 = b * b;
    return a2 + b2 > 0.0f ? a2 / (a2 + b2) : 0.0f;
}

// Russian roulette after three vertices once the throughput has fallen below 1 (as pbrt-v4):
// survival probability = max channel of the throughput, survivors divided by it. Scattering in
// media multiplies the throughput by the albedo (Collision::Weighted), so this is what ends paths
// in absorbing media; paths in albedo-1 media end by escaping, max_depth being a safety limit.
bool survive(int depth, Color* beta, Rng& rng) {
    const float m = max_component(*beta);
    if (depth < 3 || m >= 1.0f) return true;
    if (rng.uniform() >= m) return false;
    *beta /= m;
    return true;
}

// Uniforms for dimension `dim` of sample ps.s of its pixel, a Latin hypercube over the pixel's
// group of kStrataGroup consecutive samples: on either axis each of the group's strata holds one
// sample (the strata shuffled per pixel, group and dimension), jittered by j; each sample is
// uniform over [0, 1)² as s is. Used for the first vertex's direction and sky sample, where it
// lowers the error at the same time; groups of kStrataGroup, not of all of a pixel's samples,
// so that the error estimate's batches, of whole groups (strata_unit), are independent and see
// the variance per sample the render has (docs/why.md).
Vec2 stratified(const PixelSample& ps, uint64_t dim, Vec2 j) {
    const int group = ps.s / kStrataGroup;
    const uint32_t n = static_cast<uint32_t>(std::min(kStrataGroup, ps.spp - group * kStrataGroup));
    const uint32_t s = static_cast<uint32_t>(ps.s - group * kStrataGroup);
    const uint64_t key = mix64(ps.key ^ (static_cast<uint64_t>(group) << 32) ^ dim);
    const float inv = 1.0f / static_cast<float>(n);
    const uint32_t a = permute(s, n, mix64(key ^ 1)), b = permute(s, n, mix64(key ^ 2));
    return Vec2(std::min((static_cast<float>(a) + j.x) * inv, 0x1.fffffep-1f),
                std::min((static_cast<float>(b) + j.y) * inv, 0x1.fffffep-1f));
}

// The stratified dimensions of a path's first vertex.
constexpr uint64_t kDirectionDim = 0, kSkyDim = 1;

}  // namespace

// Either a phase function (travel direction) or a Lambertian lobe (normal facing the viewer).
struct PathTracer::Lobe {
    const PhaseMix* phase;              // null: diffuse
    Vec3 dir;                           // phase: incoming travel direction; diffuse: shading normal
    Color albedo;                       // diffuse
    const GuideLobes* guide = nullptr;  // phase: the guide directions are sampled from
    bool last = false;                  // the path ends at this vertex: light sampling alone
    const Vec2* sky_u = nullptr;        // the environment's light sample from these uniforms
};

PathPolicy PathPolicy::plain(const SunShadows* sun) {
    PathPolicy p(MediumVertex::Continue);
    p.sun_ = sun;
    return p;
}

PathPolicy PathPolicy::guided(const VolumeGuide* guide, const AdjointSplit& split) {
    FOGMAP_ASSERT(split.grid && split.pixels,
                  "guided paths need the adjoint grid and pixel estimate");
    PathPolicy p(MediumVertex::Guided);
    p.guide_ = guide;
    p.split_ = split;
    return p;
}

PathPolicy PathPolicy::pixel_estimate(const AdjointGrid& grid) {
    PathPolicy p(MediumVertex::EndInGrid);
    p.split_ = AdjointSplit{&grid, nullptr};
    return p;
}

PathPolicy PathPolicy::end_in_map(const VolumeMapEnd& end, const SunShadows* sun) {
    PathPolicy p(MediumVertex::EndInMap);
    p.end_ = &end;
    p.sun_ = sun;
    return p;
}

PathTracer::PathTracer(const Scene& scene, int max_depth, const PathPolicy& policy)
    : scene_(scene), max_depth_(max_depth), policy_(policy) {
    for (const Light& l : scene.lights)
        has_point_lights_ |= l.type == LightType::Point || l.type == LightType::Spot;
    for (const Medium& m : scene.media) emissive_ |= m.emission() != nullptr;
}

PathTracer::ThreadState PathTracer::make_state() const {
    ThreadState ts;
    ts.media.reserve(scene_.media.size());
    for (const Medium& m : scene_.media) ts.media.emplace_back(m);
    return ts;
}

Vec3 PathTracer::offset(const Vec3& p, const Vec3& n) const {
    return offset_point(p, n, scene_.offset_floor);
}

// Single scattering from point and spot lights over one segment's media, ∫ T σ_s p I/r² dt, by one
// equi-angular sample per light (Kulla & Fajardo 2012): pdf D / ((θ_b − θ_a)(D² + (t − Δ)²)),
// so I/r² / pdf = I (θ_b − θ_a) / D stays bounded. A scattering vertex found by delta tracking
// would instead sample points ∝ transmittance, and its shadow ray's 1/r² near the light has
// infinite variance (fireflies that grow with the sample count); so point and spot lights are
// left out of the NEE at medium vertices (direct_light) and counted here, once per segment.
Color PathTracer::point_lights_in_segment(const Ray& ray, float t_max, Rng& rng,
                                          ThreadState& ts) const {
    float ta = kInfinity, tb = 0.0f;
    for (const Medium& m : scene_.media) {
        float enter, exit;
        if (m.world_bounds().empty() ||
            !intersect_box(m.world_bounds(), ray, 0.0f, t_max, &enter, &exit))
            continue;
        ta = std::min(ta, enter);
        tb = std::max(tb, exit);
    }
    Color sum(0.0f);
    if (!(tb > ta)) return sum;
    for (const Light& light : scene_.lights) {
        if (light.type != LightType::Point && light.type != LightType::Spot) continue;
        const EquiAngular equi(ray, light.position, ta, tb);
        const float u = rng.uniform();
        float t, pdf;
        if (equi.valid()) {
            t = equi.sample(u);
            pdf = equi.pdf(t);
        } else {  // the ray passes through the light: uniform
            t = ta + u * (tb - ta);
            pdf = 1.0f / (tb - ta);
        }
        const Vec3 x = ray.at(t);
        const Color sigma_s = sigma_s_at(ts.media, x);
        if (max_component(sigma_s) <= 0.0f) continue;
        const LightSample ls = sample_light(light, x, Vec2(0.5f));
        if (ls.pdf <= 0.0f || max_component(ls.Li) <= 0.0f) continue;
        const Color T_view = ratio_track(ts.media, ray, t, rng);
        if (max_component(T_view) <= 0.0f) continue;
        const Color T_light = shadow_transmittance(
            scene_, ts.media, Ray{x, ls.wi}, ls.dist * (1.0f - kShadowRayEpsilon), rng, &ts.rays);
        const float phase = PhaseMix(ts.media, x).eval(glm::dot(ray.d, ls.wi));
        sum += T_view * sigma_s * phase * ls.Li * T_light / pdf;
    }
    return sum;
}

Color PathTracer::direct_light(const Vec3& x, const Lobe& lobe, Rng& rng, ThreadState& ts) const {
    Color sum(0.0f);
    for (size_t li = 0; li < scene_.lights.size(); ++li) {
        const Light& light = scene_.lights[li];
        // Point and spot lights reach medium vertices through point_lights_in_segment.
        if (lobe.phase && (light.type == LightType::Point || light.type == LightType::Spot))
            continue;
        // Sample from the offset origin so the shadow ray's length is measured from where it
        // starts (else the light itself can sit inside the margin).
        const Vec3 origin = lobe.phase ? x : offset(x, lobe.dir);
        const Vec2 u(rng.uniform(), rng.uniform());
        LightSample s;
        if (light.type == LightType::Environment) {  // constant: by the phase or the cosine
            s.Li = light.radiance;
            if (lobe.phase) {
                s.wi = lobe.sky_u ? lobe.phase->sample(lobe.dir, rng.uniform(), *lobe.sky_u, &s.pdf)
                                  : lobe.phase->sample(lobe.dir, rng, &s.pdf);
            } else {
                s.wi = sample_cosine_hemisphere(lobe.dir, lobe.sky_u ? *lobe.sky_u : u);
                s.pdf = std::max(glm::dot(lobe.dir, s.wi), 0.0f) * kInvPi;
            }
        } else {
            s = sample_light(light, origin, u);
        }
        if (s.pdf <= 0.0f || max_component(s.Li) <= 0.0f) continue;

        Color f;
        float lobe_pdf;
        if (lobe.phase) {
            f = Color(lobe.phase->eval(glm::dot(lobe.dir, s.wi)));
            lobe_pdf =
                lobe.guide ? policy_.guide().pdf(*lobe.guide, *lobe.phase, lobe.dir, s.wi) : f.x;
        } else {
            const float cos = glm::dot(lobe.dir, s.wi);
            if (cos <= 0.0f) continue;
            lobe_pdf = cos * kInvPi;
            f = lobe.albedo * lobe_pdf;
        }
        const Color T = shadow(li, origin, s, rng, ts);
        if (max_component(T) <= 0.0f) continue;
        // A path that ends here has no phase-sampled ray to take the rest of the MIS weight.
        const float w = light.is_delta() || lobe.last ? 1.0f : power_heuristic(s.pdf, lobe_pdf);
        sum += f * s.Li * T * (w / s.pdf);
    }
    return sum;
}

Color PathTracer::shadow(size_t li, const Vec3& origin, const LightSample& s, Rng& rng,
                         ThreadState& ts) const {
    if (!policy_.sun_covers(li))
        return shadow_transmittance(scene_, ts.media, Ray{origin, s.wi},
                                    s.dist * (1.0f - kShadowRayEpsilon), rng, &ts.rays);
    bool blocked = false;  // surfaces by Embree, media from the grid
    if (scene_.surfaces) {
        ++ts.rays;
        blocked = scene_.surfaces->occluded(Ray{origin, s.wi}, 0.0f, s.dist);
    }
    ++ts.lookups;
    return blocked ? Color(0.0f) : policy_.sun().transmittance(li, origin);
}

// Counts a scattering or bounce vertex of p; false (counted as capped) when max_depth has been
// reached. *strata: the pixel's strata at the first vertex, else null.
bool PathTracer::new_vertex(Path& p, Vertex v, ThreadState& ts, const PixelSample** strata) const {
    if (p.depth >= max_depth_) {
        ++ts.capped;
        return false;
    }
    *strata = p.depth == 0 ? p.strata : nullptr;
    ++p.depth;
    if (v == Vertex::Specular) {
        p.specular_after |= p.first != Vertex::None;
    } else {
        if (p.first == Vertex::None) p.first = v;
        ++p.scatters;
    }
    return true;
}

Layer PathTracer::layer_of(const Path& p, Term term) {
    const bool scattered = term == Term::Scattered;
    const int n = p.scatters + (scattered ? 1 : 0);
    if (n == 0) return term == Term::Emitted ? Layer::Emission : Layer::Direct;
    if (p.first == Vertex::Medium || (p.first == Vertex::None && scattered))
        return n == 1 ? Layer::VolumeSingle : Layer::VolumeMultiple;
    if (n > 1) return Layer::Indirect;
    return p.specular_after ? Layer::Caustic : Layer::Direct;
}

void PathTracer::add(const Path& p, Term term, const Color& c, Color* L, ThreadState& ts) {
    *L += c;
    if (ts.layered) ts.layers[static_cast<size_t>(layer_of(p, term))] += c;
}

// A scattering vertex in a medium at x, reached along p.ray: the direct light, then either the
// path's end (ends_here) or a phase (or guide) sampled direction for p. False: the path ends here.
bool PathTracer::scatter(Path& p, const Vec3& x, Color* L, Rng& rng, ThreadState& ts) const {
    const PixelSample* first = nullptr;
    if (!new_vertex(p, Vertex::Medium, ts, &first)) return false;
    const PhaseMix phase(ts.media, x);
    if (ends_here(p, x)) {
        end_path(p, x, phase, L, rng, ts);
        return false;
    }
    const bool guided = policy_.guides(p.depth);
    if (guided) {
        ++ts.lookups;
        policy_.guide().prepare(x, p.ray.d, phase, ts.neighbors, &ts.lobes);
        ts.gathered += ts.neighbors.size();
    }
    Vec2 sky_u;
    if (first) sky_u = stratified(*first, kSkyDim, Vec2(rng.uniform(), rng.uniform()));
    Lobe lobe{&phase, p.ray.d, Color(0.0f), guided ? &ts.lobes : nullptr};
    if (first) lobe.sky_u = &sky_u;
    const Color direct = direct_light(x, lobe, rng, ts);
    add(p, Term::Light, p.beta * direct, L, ts);
    // split() plays the roulette.
    const bool splits = policy_.kind() == MediumVertex::Guided && ts.pixel_estimate > 0.0f;
    const int copies = splits ? split(p, x, phase, direct, rng, ts) : 1;
    if (copies == 0) return false;
    if (copies > 1) {  // every copy's direction before any is traced (tracing overwrites ts.lobes)
        std::array<Path, AdjointSplit::kMaxSplit - 1> more;
        for (int c = 0; c + 1 < copies; ++c) {
            more[c] = p;
            next_direction(more[c], x, phase, guided, nullptr, rng, ts);
        }
        next_direction(p, x, phase, guided, first, rng, ts);
        for (int c = 0; c + 1 < copies; ++c) *L += trace(more[c], rng, ts);
        return true;
    }
    next_direction(p, x, phase, guided, first, rng, ts);
    return splits || survive(p.depth, &p.beta, rng);
}

bool PathTracer::ends_here(Path& p, const Vec3& x) const {
    switch (policy_.kind()) {
        case MediumVertex::EndInMap:
            return policy_.end().ends_at(x, ++p.gather_vertices);
        case MediumVertex::EndInGrid:
            return true;
        case MediumVertex::Continue:
        case MediumVertex::Guided:
            return false;
    }
    return false;
}

// Direct light by a shadow ray (the whole of its MIS weight: no direction is sampled after it),
// the rest from the map or from L̃.
void PathTracer::end_path(const Path& p, const Vec3& x, const PhaseMix& phase, Color* L, Rng& rng,
                          ThreadState& ts) const {
    add(p, Term::Light,
        p.beta * direct_light(x, Lobe{&phase, p.ray.d, Color(0.0f), nullptr, true}, rng, ts), L,
        ts);
    ++ts.lookups;
    if (policy_.kind() == MediumVertex::EndInMap) {
        ts.neighbors.clear();
        VolumeMapEnd::Parts parts;
        const Color map =
            p.beta * policy_.end().inscattered(x, p.ray.d, phase, ts.neighbors, &parts);
        add(p, Term::Scattered, map, L, ts);
        add_photon_delta(map, parts.shares, &ts.photon_delta);
        for (size_t h = 0; h < 2; ++h) ts.bias_half[h] += parts.bias[h] * map;
        ts.batched = true;
        ts.gathered += ts.neighbors.size();
    } else {
        add(p, Term::Scattered, p.beta * policy_.split().grid->at(x, p.ray.d, phase), L, ts);
    }
}

void PathTracer::next_direction(Path& q, const Vec3& x, const PhaseMix& phase, bool guided,
                                const PixelSample* strata, Rng& rng, ThreadState& ts) const {
    Vec3 wi;
    if (guided) {  // one-sample MIS of phase and guide: weight f / p_mix
        wi = policy_.guide().sample(ts.lobes, phase, q.ray.d, rng, &q.prev_pdf);
        q.env_pdf = phase.eval(glm::dot(q.ray.d, wi));
        q.beta *= q.env_pdf / q.prev_pdf;
    } else if (strata) {
        const float pick_u = rng.uniform();
        const Vec2 u = stratified(*strata, kDirectionDim, Vec2(rng.uniform(), rng.uniform()));
        wi = phase.sample(q.ray.d, pick_u, u, &q.prev_pdf);
        q.env_pdf = q.prev_pdf;
    } else {
        wi = phase.sample(q.ray.d, rng, &q.prev_pdf);  // weight phase/pdf = 1
        q.env_pdf = q.prev_pdf;
    }
    q.specular = false;
    q.prev_p = x;
    q.ray = Ray{x, wi};
}

// AdjointSplit (path_tracer.h): n = ⌈β (L̃ + direct) / Ĩ⌉ copies above the window, one path
// within it, the plain roulette below it.
int PathTracer::split(Path& p, const Vec3& x, const PhaseMix& phase, const Color& direct, Rng& rng,
                      ThreadState& ts) const {
    ++ts.lookups;
    const float ratio = average(p.beta * (policy_.split().grid->at(x, p.ray.d, phase) + direct)) /
                        ts.pixel_estimate;
    if (!(ratio >= AdjointSplit::kBelow)) return survive(p.depth, &p.beta, rng) ? 1 : 0;
    if (ratio <= AdjointSplit::kAbove) return 1;
    const int n = std::min({int(std::ceil(ratio)), AdjointSplit::kMaxSplit, 1 + ts.splits_left});
    ts.splits_left -= n - 1;
    p.beta /= float(n);
    return n;
}

Color PathTracer::radiance(const Ray& camera_ray, Rng& rng, ThreadState& ts,
                           const PixelSample* strata) const {
    Path p;
    p.ray = camera_ray;
    p.strata = strata;
    if (policy_.kind() == MediumVertex::Guided) {
        const Image& pixels = *policy_.split().pixels;
        ts.pixel_estimate = strata ? average(pixels.at(strata->x, strata->y)) : 0.0f;
        ts.splits_left = AdjointSplit::kSplitBudget;
    }
    p.prev_p = camera_ray.o;
    ts.photon_delta.fill(Color(0.0f));
    ts.bias_half.fill(Color(0.0f));
    ts.batched = false;
    if (ts.layered) ts.layers.fill(Color(0.0f));
    if (ts.media.empty() || policy_.kind() != MediumVertex::EndInMap) return trace(p, rng, ts);
    return pick_segment(p, rng, ts);
}

// Paths that end in the map: the segment's one ratio-tracking walk gives an in-scattering point
// (weight ≈ 1 − T) and the transmittance to what lies behind, and the path continues from both,
// instead of delta tracking's either-or (see the header).
Color PathTracer::pick_segment(Path p, Rng& rng, ThreadState& ts) const {
    std::optional<SurfaceHit> hit;
    float t_max = kInfinity;
    if (scene_.surfaces) {
        ++ts.rays;
        hit = scene_.surfaces->intersect(p.ray, 0.0f, kInfinity);
        if (hit) t_max = hit->t;
    }
    Color L(0.0f), emitted(0.0f);
    if (has_point_lights_ && p.depth < max_depth_)
        add(p, Term::Scattered, p.beta * point_lights_in_segment(p.ray, t_max, rng, ts), &L, ts);
    const InscatterPick pick =
        ratio_track_pick(ts.media, p.ray, t_max, rng, emissive_ ? &emitted : nullptr);
    add(p, Term::Emitted, p.beta * emitted, &L, ts);
    if (pick.medium >= 0) {
        Path m = p;
        m.beta = p.beta * pick.weight;
        if (scatter(m, m.ray.at(pick.t), &L, rng, ts)) L += trace(m, rng, ts);
    }
    if (max_component(pick.transmittance) > 0.0f) {
        p.beta *= pick.transmittance;
        L += trace(p, rng, ts, &hit);
    }
    return L;
}

Color PathTracer::trace(Path p, Rng& rng, ThreadState& ts,
                        const std::optional<SurfaceHit>* first_hit) const {
    Color L(0.0f);
    for (bool first = true;; first = false) {
        const bool picked = first && first_hit;  // this segment's hit and media: pick_segment's
        std::optional<SurfaceHit> hit;
        if (picked) {
            hit = *first_hit;
        } else if (scene_.surfaces) {
            ++ts.rays;
            hit = scene_.surfaces->intersect(p.ray, 0.0f, kInfinity);
        }
        if (!ts.media.empty() && !picked) {
            const Segment s = media_segment(p, hit ? hit->t : kInfinity, &L, rng, ts);
            if (s == Segment::Ended) break;
            if (s == Segment::Scattered) continue;
        }
        if (!hit) {
            add_escaped(p, &L, ts);
            break;
        }
        if (hit->light >= 0) {  // quad lights are black emitters
            const Light& light = scene_.lights[hit->light];
            const Color Le = quad_radiance(light, p.ray.d);
            const float w =
                p.specular
                    ? 1.0f
                    : power_heuristic(p.prev_pdf, light_pdf(light, p.prev_p, p.ray.d, hit->t));
            add(p, Term::Light, p.beta * Le * w, &L, ts);
            break;
        }
        if (hit->material < 0 || !bounce(p, *hit, &L, rng, ts)) break;
    }
    return L;
}

PathTracer::Segment PathTracer::media_segment(Path& p, float t_max, Color* L, Rng& rng,
                                              ThreadState& ts) const {
    if (has_point_lights_ && p.depth < max_depth_)
        add(p, Term::Scattered, p.beta * point_lights_in_segment(p.ray, t_max, rng, ts), L, ts);
    Color emitted(0.0f);
    const TrackResult tr = delta_track(ts.media, p.ray, t_max, rng, &p.beta, Collision::Weighted,
                                       emissive_ ? &emitted : nullptr);
    add(p, Term::Emitted, emitted, L, ts);
    if (tr.event == TrackEvent::Absorbed) return Segment::Ended;
    if (tr.event != TrackEvent::Scattered) return Segment::Passed;
    return scatter(p, p.ray.at(tr.t), L, rng, ts) ? Segment::Scattered : Segment::Ended;
}

void PathTracer::add_escaped(const Path& p, Color* L, ThreadState& ts) const {
    for (const Light& light : scene_.lights) {
        if (!light.is_infinite()) continue;
        const Color Le = escaped_radiance(light, p.ray.d);
        if (max_component(Le) <= 0.0f) continue;
        // The environment's light sample had the lobe's own pdf (direct_light).
        const float light_p = light.type == LightType::Environment
                                  ? p.env_pdf
                                  : light_pdf(light, p.prev_p, p.ray.d, kInfinity);
        const float w = p.specular ? 1.0f : power_heuristic(p.prev_pdf, light_p);
        add(p, Term::Light, p.beta * Le * w, L, ts);
    }
}

// Specular: the material's reflected or refracted ray; diffuse: direct light and a
// cosine-sampled direction.
bool PathTracer::bounce(Path& p, const SurfaceHit& hit, Color* L, Rng& rng, ThreadState& ts) const {
    const Material& mat = scene_.materials[hit.material];
    const PixelSample* strata = nullptr;
    if (!new_vertex(p, mat.is_specular() ? Vertex::Specular : Vertex::Diffuse, ts, &strata))
        return false;
    const Vec3 n = glm::dot(p.ray.d, hit.ng) < 0.0f ? hit.ng : -hit.ng;  // faces the ray
    Vec2 u(rng.uniform(), rng.uniform());
    if (strata) u = stratified(*strata, kDirectionDim, u);
    if (mat.is_specular()) {
        const SpecularScatter sc = scatter_specular(mat, p.ray.d, hit.p, hit.ng, u.x,
                                                    Transport::Radiance, scene_.offset_floor);
        p.beta *= sc.weight;
        p.ray = sc.ray;
        p.specular = true;
    } else {
        Lobe lobe{nullptr, n, mat.albedo};
        Vec2 sky_u;
        if (strata) {
            sky_u = stratified(*strata, kSkyDim, Vec2(rng.uniform(), rng.uniform()));
            lobe.sky_u = &sky_u;
        }
        add(p, Term::Light, p.beta * direct_light(hit.p, lobe, rng, ts), L, ts);
        const Vec3 wi = sample_cosine_hemisphere(n, u);
        p.prev_pdf = std::max(glm::dot(wi, n), 0.0f) * kInvPi;
        p.env_pdf = p.prev_pdf;  // the environment's light sample: the same cosine
        p.beta *= mat.albedo;    // f cos / pdf = albedo
        p.specular = false;
        ++p.gather_vertices;
        p.ray = Ray{offset(hit.p, n), wi};
    }
    p.prev_p = hit.p;
    return survive(p.depth, &p.beta, rng);
}

static_assert(Photon::kBatches == kBatches, "FilmSample::photon_delta: one per photon batch");

Film render_path(const Scene& scene, const RenderSettings& settings, bool quiet, RenderStats* stats,
                 const PathPolicy& policy, TileShare tiles, bool layered, GivenSamples given) {
    const PathTracer tracer(scene, settings.max_depth, policy);
    const PhotonParts parts =
        policy.kind() == MediumVertex::EndInMap ? policy.end().parts() : PhotonParts::None;
    return render_film(
        Camera(scene.camera), settings.spp, settings.seed, tiles, layered, parts,
        strata_unit(settings.spp), settings.adaptive, quiet, stats,
        [&] {
            PathTracer::ThreadState ts = tracer.make_state();
            ts.layered = layered;
            return ts;
        },
        [&](const Ray& ray, Rng& rng, PathTracer::ThreadState& ts, const PixelSample& ps) {
            set_time(ts.media, ps.time);
            FilmSample sample;
            sample.beauty = tracer.radiance(ray, rng, ts, &ps);
            sample.layers = ts.layers;
            sample.batched = ts.batched;
            if (ts.batched) {
                sample.photon_delta = ts.photon_delta;
                sample.bias_half = ts.bias_half;
            }
            return sample;
        },
        given);
}

Image render_pixel_estimate(const Scene& scene, const RenderSettings& settings,
                            const AdjointGrid& grid, RenderStats* stats, TileShare tiles) {
    RenderSettings pre = settings;
    pre.spp = kPixelEstimateSpp;
    pre.adaptive = false;
    pre.seed = mix64(settings.seed ^ stream::kPixelEstimate);  // not the render's samples
    const Image film =
        render_path(scene, pre, /*quiet=*/true, stats, PathPolicy::pixel_estimate(grid), tiles)
            .beauty;
    // Within the pixel's tile: a rank rendering a share of the tiles gets the same Ĩ.
    Image out(film.width, film.height);
    for (int y = 0; y < film.height; ++y)
        for (int x = 0; x < film.width; ++x) {
            Color sum(0.0f);
            int n = 0;
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    const int u = x + dx, v = y + dy;
                    if (u < 0 || v < 0 || u >= film.width || v >= film.height ||
                        u / kTile != x / kTile || v / kTile != y / kTile)
                        continue;
                    sum += film.at(u, v);
                    ++n;
                }
            out.at(x, y) = sum / float(n);
        }
    return out;
}

}  // namespace fogmap
