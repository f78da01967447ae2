#include "render/path_tracer.h"

#include "media/henyey_greenstein.h"
#include "render/camera.h"
#include "render/tiles.h"

#include <optional>

namespace fogmap {

namespace {

float power_heuristic(float a, float b) {
    const float a2 = a * a, b2 = b * b;
    return a2 + b2 > 0.0f ? a2 / (a2 + b2) : 0.0f;
}

// Russian roulette after three vertices once the throughput has fallen below 1 (as pbrt-v4):
// survival probability = max channel of the throughput. Paths in albedo-1 media end by escaping
// or at max_depth, never by a growing weight.
bool survive(int depth, Color* beta, Rng& rng) {
    const float m = max_component(*beta);
    if (depth < 3 || m >= 1.0f) return true;
    if (rng.uniform() >= m) return false;
    *beta /= m;
    return true;
}

}  // namespace

// Either a phase function (travel direction, g) or a Lambertian lobe (normal facing the viewer).
struct PathTracer::Lobe {
    bool phase;
    Vec3 dir;      // phase: incoming travel direction; diffuse: shading normal
    float g;       // phase
    Color albedo;  // diffuse
};

PathTracer::PathTracer(const Scene& scene, int max_depth) : scene_(scene), max_depth_(max_depth) {
    const float extent = scene.bounds.empty() ? 1.0f : glm::length(scene.bounds.extent());
    offset_floor_ = 1e-6f * extent;
}

PathTracer::ThreadState PathTracer::make_state() const {
    ThreadState ts;
    ts.media.reserve(scene_.media.size());
    for (const Medium& m : scene_.media) ts.media.emplace_back(m);
    return ts;
}

Vec3 PathTracer::offset(const Vec3& p, const Vec3& n) const {
    return offset_point(p, n, offset_floor_);
}

Color PathTracer::direct_light(const Vec3& x, const Lobe& lobe, Rng& rng, ThreadState& ts) const {
    Color sum(0.0f);
    for (const Light& light : scene_.lights) {
        // Sample from the offset origin so the shadow ray's length is measured from where it
        // starts (else the light itself can sit inside the margin).
        const Vec3 origin = lobe.phase ? x : offset(x, lobe.dir);
        const Vec2 u(rng.uniform(), rng.uniform());
        const LightSample s = sample_light(light, origin, u);
        if (s.pdf <= 0.0f || max_component(s.Li) <= 0.0f) continue;

        Color f;
        float lobe_pdf;
        if (lobe.phase) {
            lobe_pdf = hg_phase(glm::dot(lobe.dir, s.wi), lobe.g);
            f = Color(lobe_pdf);
        } else {
            const float cos = glm::dot(lobe.dir, s.wi);
            if (cos <= 0.0f) continue;
            lobe_pdf = cos * kInvPi;
            f = lobe.albedo * lobe_pdf;
        }
        const Ray shadow{origin, s.wi};
        const float t_max = s.dist * (1.0f - 1e-4f);
        if (scene_.surfaces) {
            ++ts.rays;
            if (scene_.surfaces->occluded(shadow, 0.0f, t_max)) continue;
        }
        Color T(1.0f);
        if (!ts.media.empty()) {
            T = ratio_track(ts.media, shadow, t_max, rng);
            if (max_component(T) <= 0.0f) continue;
        }
        const float w = light.is_delta() ? 1.0f : power_heuristic(s.pdf, lobe_pdf);
        sum += f * s.Li * T * (w / s.pdf);
    }
    return sum;
}

Color PathTracer::radiance(const Ray& camera_ray, Rng& rng, ThreadState& ts) const {
    Color L(0.0f), beta(1.0f);
    Ray ray = camera_ray;
    bool specular = true;  // the last vertex was the camera or a specular bounce: no MIS
    float prev_pdf = 0.0f;
    Vec3 prev_p = ray.o;
    int depth = 0;
    for (;;) {
        std::optional<SurfaceHit> hit;
        float t_max = kInfinity;
        if (scene_.surfaces) {
            ++ts.rays;
            hit = scene_.surfaces->intersect(ray, 0.0f, kInfinity);
            if (hit) t_max = hit->t;
        }
        if (!ts.media.empty()) {
            const TrackResult tr = delta_track(ts.media, ray, t_max, rng, &beta);
            if (tr.event == TrackEvent::Absorbed) break;
            if (tr.event == TrackEvent::Scattered) {
                if (depth >= max_depth_) {
                    ++ts.capped;
                    break;
                }
                ++depth;
                const Vec3 x = ray.at(tr.t);
                const float g = scene_.media[tr.medium].params().g;
                L += beta * direct_light(x, Lobe{true, ray.d, g, Color(0.0f)}, rng, ts);
                const Vec2 u(rng.uniform(), rng.uniform());
                const Vec3 wi = hg_sample(ray.d, g, u, &prev_pdf);  // weight phase/pdf = 1
                specular = false;
                prev_p = x;
                ray = Ray{x, wi};
                if (!survive(depth, &beta, rng)) break;
                continue;
            }
        }
        if (!hit) {
            for (const Light& light : scene_.lights) {
                if (!light.is_infinite()) continue;
                const Color Le = escaped_radiance(light, ray.d);
                if (max_component(Le) <= 0.0f) continue;
                const float w =
                    specular
                        ? 1.0f
                        : power_heuristic(prev_pdf, light_pdf(light, prev_p, ray.d, kInfinity));
                L += beta * Le * w;
            }
            break;
        }
        if (hit->light >= 0) {  // quad lights are black emitters
            const Light& light = scene_.lights[hit->light];
            const Color Le = quad_radiance(light, ray.d);
            const float w =
                specular ? 1.0f
                         : power_heuristic(prev_pdf, light_pdf(light, prev_p, ray.d, hit->t));
            L += beta * Le * w;
            break;
        }
        if (hit->material < 0) break;
        if (depth >= max_depth_) {
            ++ts.capped;
            break;
        }
        ++depth;
        const Material& mat = scene_.materials[hit->material];
        const bool front = glm::dot(ray.d, hit->ng) < 0.0f;
        const Vec3 n = front ? hit->ng : -hit->ng;  // faces the incoming ray
        const Vec2 u(rng.uniform(), rng.uniform());
        switch (mat.type) {
            case MaterialType::Diffuse: {
                L += beta * direct_light(hit->p, Lobe{false, n, 0.0f, mat.albedo}, rng, ts);
                const Vec3 wi = sample_cosine_hemisphere(n, u);
                prev_pdf = std::max(glm::dot(wi, n), 0.0f) * kInvPi;
                beta *= mat.albedo;  // f cos / pdf = albedo
                specular = false;
                ray = Ray{offset(hit->p, n), wi};
                break;
            }
            case MaterialType::Mirror:
                beta *= mat.albedo;
                specular = true;
                ray = Ray{offset(hit->p, n), glm::normalize(reflect(ray.d, n))};
                break;
            case MaterialType::Glass: {
                const float eta = front ? mat.ior : 1.0f / mat.ior;
                const float F = fresnel_dielectric(-glm::dot(ray.d, n), eta);
                Vec3 wt;
                if (u.x < F || !refract(ray.d, n, eta, &wt)) {
                    ray = Ray{offset(hit->p, n), glm::normalize(reflect(ray.d, n))};
                } else {
                    beta /= eta * eta;  // radiance is compressed by (n_t/n_i)^2 crossing in
                    ray = Ray{offset(hit->p, -n), wt};
                }
                specular = true;
                break;
            }
        }
        prev_p = hit->p;
        if (!survive(depth, &beta, rng)) break;
    }
    return L;
}

Image render_path(const Scene& scene, const RenderSettings& settings, bool quiet,
                  RenderStats* stats) {
    const Camera camera(scene.desc.camera);
    const PathTracer tracer(scene, settings.max_depth);
    const int w = camera.width(), h = camera.height();
    Image image(w, h);
    render_tiles(
        w, h, settings, quiet, stats, [&] { return tracer.make_state(); },
        [&](int x, int y, PathTracer::ThreadState& ts) {
            Color sum(0.0f);
            uint64_t dropped = 0;
            const uint64_t pixel = static_cast<uint64_t>(y) * w + x;
            const uint64_t jitter_key = pixel_key(settings.seed, pixel);
            for (int s = 0; s < settings.spp; ++s) {
                Rng rng(settings.seed, pixel, static_cast<uint64_t>(s));
                const Vec2 j = pixel_jitter(s, settings.spp, jitter_key,
                                            Vec2(rng.uniform(), rng.uniform()));
                const Color c = tracer.radiance(camera.generate(x + j.x, y + j.y), rng, ts);
                if (is_finite(c))
                    sum += c;
                else
                    ++dropped;
            }
            image.at(x, y) = sum / static_cast<float>(settings.spp);
            return dropped;
        });
    return image;
}

}  // namespace fogmap
