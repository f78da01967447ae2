#include "photon/photon_pass.h"

#include "core/progress.h"
#include "core/sampling.h"
#include "core/timer.h"
#include "media/phase.h"
#include "media/ray_march.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <array>
#include <cstdio>

namespace fogmap {

namespace {

constexpr uint64_t kPhotonStream =
    0x50484F544F4Eull;  // "PHOTON": photons never share pixels' streams
constexpr uint64_t kBatch = 1u << 15;
constexpr uint64_t kChunk = 512;

constexpr int kGlobal = static_cast<int>(PhotonMapId::Global);
constexpr int kCaustic = static_cast<int>(PhotonMapId::Caustic);
constexpr int kVolume = static_cast<int>(PhotonMapId::Volume);

/// Lights chosen in proportion to their power; a photon leaves light l with Φ_l / avg(Φ_l).
struct Emitter {
    std::vector<float> light_cdf;
    std::vector<Color> light_relative_power;
};

}  // namespace

PhotonTracer::PhotonTracer(const Scene& scene, const MarchSettings& march, int max_bounces)
    : scene_(scene),
      marcher_(scene.media, march),
      method_(march.method),
      max_bounces_(max_bounces) {}

TracedPath PhotonTracer::trace(Ray ray, Color power, Rng& rng,
                               std::vector<Medium::Sampler>& samplers, uint32_t index,
                               std::vector<TaggedPhoton>* out) const {
    const Scene& scene = scene_;
    const std::array<bool, 3>& store = store_;
    auto deposit = [&](int map, const Photon& photon) {
        out->push_back({index, static_cast<PhotonMapId>(map), photon});
    };
    auto ended = [&](PathEnd end, int depth) { return TracedPath{end, ray, power, depth}; };
    bool specular_chain = true;  // every interaction so far was specular
    const bool has_media = !samplers.empty();
    const int max_bounces = max_bounces_;
    for (int depth = 0; depth < max_bounces; ++depth) {
        std::optional<SurfaceHit> hit;
        float t_max = kInfinity;
        if (scene.surfaces) {
            hit = scene.surfaces->intersect(ray, 0.0f, kInfinity);
            if (hit) t_max = hit->t;
        }
        if (has_media) {
            bool scattered = false;
            Vec3 x;
            if (method_ == FreePathMethod::March) {
                const RayMarcher::FreePath fp =
                    marcher_.sample_free_path(samplers, ray, t_max, rng);
                power *= fp.weight;
                if (fp.collided) {
                    x = fp.x;
                    // Russian roulette on the albedo; power changes only by channel ratios.
                    // Only scattering events are stored (absorptions would count σ_t, not σ_s).
                    const double p = (double(fp.sigma_s.x) + fp.sigma_s.y + fp.sigma_s.z) /
                                     (double(fp.sigma_t.x) + fp.sigma_t.y + fp.sigma_t.z);
                    if (rng.uniform() >= p) return ended(PathEnd::Absorbed, depth + 1);
                    power *= fp.sigma_s / (fp.sigma_t * static_cast<float>(p));
                    if (depth > 0 && store[kVolume]) deposit(kVolume, Photon(x, ray.d, power));
                    scattered = true;
                }
            } else {
                Color beta(1.0f);
                const TrackResult tr = delta_track(samplers, ray, t_max, rng, &beta);
                power *= beta;
                if (tr.event == TrackEvent::Absorbed) return ended(PathEnd::Absorbed, depth + 1);
                if (tr.event == TrackEvent::Scattered) {
                    x = ray.at(tr.t);
                    if (depth > 0 && store[kVolume]) deposit(kVolume, Photon(x, ray.d, power));
                    scattered = true;
                }
            }
            if (scattered) {
                float pdf;
                ray = Ray{x, PhaseMix(samplers, x).sample(ray.d, rng, &pdf)};
                specular_chain = false;
                continue;
            }
        }
        if (!hit) return ended(PathEnd::Escaped, depth);
        if (hit->material < 0) return ended(PathEnd::Absorbed, depth);
        const Material& mat = scene.materials[hit->material];
        if (mat.is_specular()) {
            const SpecularScatter sc = scatter_specular(mat, ray.d, hit->p, hit->ng, rng.uniform(),
                                                        Transport::Importance, scene.offset_floor);
            // Russian roulette keeps the power constant (DESIGN.md, Photons): survive with the
            // mean weight, carry on reweighted by the channel ratios.
            const float p = average(sc.weight);
            if (p < 1.0f) {
                if (rng.uniform() >= p) return ended(PathEnd::Absorbed, depth + 1);
                power *= sc.weight / p;
            }
            ray = sc.ray;
            continue;
        }
        const Vec3 n = glm::dot(ray.d, hit->ng) < 0.0f ? hit->ng : -hit->ng;  // faces the photon
        if (depth > 0) {
            // Surface photons keep the normal of the side they arrived on (Lambertian surfaces
            // need no direction; see photon.h).
            const bool caustic = specular_chain;
            if (store[kGlobal])
                deposit(kGlobal, Photon(hit->p, n, power, caustic ? Photon::kCaustic : 0));
            if (caustic && store[kCaustic]) deposit(kCaustic, Photon(hit->p, n, power));
        }
        const float p = average(mat.albedo);
        if (rng.uniform() >= p) return ended(PathEnd::Absorbed, depth + 1);
        power *= mat.albedo / p;
        ray = Ray{offset_point(hit->p, n, scene.offset_floor),
                  sample_cosine_hemisphere(n, Vec2(rng.uniform(), rng.uniform()))};
        specular_chain = false;
    }
    return ended(PathEnd::BounceCap, max_bounces);
}

PhotonPassResult trace_photons(const Scene& scene, const Plan& plan, const PhotonSettings& settings,
                               const MarchSettings& march, uint64_t seed, bool quiet) {
    const Timer timer;
    PhotonPassResult result;
    std::array<StoredPhotons*, 3> maps{nullptr, nullptr, nullptr};
    if (plan.global_map.on) maps[kGlobal] = &result.global.emplace();
    if (plan.caustic_map.on) maps[kCaustic] = &result.caustic.emplace();
    if (plan.volume_map.on) maps[kVolume] = &result.volume.emplace();
    const std::array<uint64_t, 3> budgets{settings.global, settings.caustic, settings.volume};
    uint64_t largest = 0;
    for (int m = 0; m < 3; ++m) {
        if (!maps[m]) continue;
        maps[m]->budget = budgets[m];
        maps[m]->photons.reserve(budgets[m] + 64);
        largest = std::max(largest, budgets[m]);
    }
    if (largest == 0) return result;

    PhotonTracer tracer(scene, march, settings.max_bounces);
    Emitter emitter;
    float cumulative = 0.0f;
    for (const Light& l : scene.lights) {
        const Color power = light_power(l, scene.bounds);
        const float avg = average(power);
        cumulative += avg;
        emitter.light_cdf.push_back(cumulative);
        emitter.light_relative_power.push_back(avg > 0.0f ? power / avg : Color(0.0f));
    }
    result.total_power = cumulative;
    if (!(cumulative > 0.0f)) {
        result.warnings.push_back("no light emits power: no photons traced");
        return result;
    }
    // Sun and sky photons concentrate on the media when a volume map is wanted and
    // photons.media_fraction asks for it (light.h PhotonFocus).
    PhotonFocus focus;
    if (maps[kVolume])
        for (const Medium& m : scene.media) focus.bounds.extend(m.world_bounds());
    focus.fraction = settings.media_fraction;
    const PhotonFocus* focused = focus.bounds.empty() || focus.fraction <= 0.0f ? nullptr : &focus;
    // Light ∝ power, then a photon from it, traced.
    struct ChunkOut {
        std::vector<TaggedPhoton> photons;
        uint64_t capped = 0;
        double capped_power = 0.0;  // Σ average(power) of capped paths (a photon starts at ~1)
    };
    auto emit = [&](uint32_t index, Rng& rng, std::vector<Medium::Sampler>& samplers,
                    ChunkOut& out) {
        const float pick = rng.uniform() * emitter.light_cdf.back();
        const size_t li = std::min<size_t>(
            std::upper_bound(emitter.light_cdf.begin(), emitter.light_cdf.end(), pick) -
                emitter.light_cdf.begin(),
            emitter.light_cdf.size() - 1);
        Ray ray;
        float weight;
        if (!sample_photon(scene.lights[li], scene.bounds, focused, rng, &ray, &weight)) return;
        const TracedPath path = tracer.trace(ray, emitter.light_relative_power[li] * weight, rng,
                                             samplers, index, &out.photons);
        if (path.end == PathEnd::BounceCap) {
            ++out.capped;
            out.capped_power += average(path.power);
        }
    };

    const uint64_t cap = settings.max_emitted > 0 ? settings.max_emitted : 100 * largest;
    std::array<uint64_t, 3> full_at{0, 0, 0};
    auto unfilled = [&] {
        for (int m = 0; m < 3; ++m)
            if (maps[m] && maps[m]->budget > 0 && full_at[m] == 0) return true;
        return false;
    };
    Progress progress("photons", 1000, quiet);
    uint64_t shown = 0;
    while (unfilled() && result.emitted < cap) {
        const uint64_t n = std::min(kBatch, cap - result.emitted);
        const uint64_t chunks = (n + kChunk - 1) / kChunk;
        std::vector<ChunkOut> out(chunks);
        std::array<bool, 3> store;
        for (int m = 0; m < 3; ++m) store[m] = maps[m] && full_at[m] == 0;
        tracer.set_store(store);
        const uint64_t base = result.emitted;
        tbb::parallel_for(tbb::blocked_range<uint64_t>(0, chunks, 1), [&](const auto& r) {
            std::vector<Medium::Sampler> samplers;
            for (const Medium& m : scene.media) samplers.emplace_back(m);
            for (uint64_t c = r.begin(); c != r.end(); ++c) {
                for (uint64_t i = c * kChunk; i < std::min(n, (c + 1) * kChunk); ++i) {
                    Rng rng(seed, base + i, kPhotonStream);
                    emit(static_cast<uint32_t>(i), rng, samplers, out[c]);
                }
            }
        });
        // Merge in emission order; a map stops at the photon that fills it (whole path kept).
        for (const ChunkOut& chunk : out) {
            result.capped += chunk.capped;
            result.capped_power += chunk.capped_power;
            for (const TaggedPhoton& t : chunk.photons) {
                const int m = static_cast<int>(t.map);
                StoredPhotons& map = *maps[m];
                const uint64_t e = base + t.index;
                if (full_at[m] != 0 && e >= full_at[m]) continue;
                map.photons.push_back(t.photon);
                if (map.photons.size() >= map.budget && full_at[m] == 0) full_at[m] = e + 1;
            }
        }
        result.emitted += n;
        double fill = 1.0;
        for (int m = 0; m < 3; ++m)
            if (maps[m] && maps[m]->budget > 0)
                fill = std::min(fill, double(maps[m]->photons.size()) / maps[m]->budget);
        const uint64_t now =
            static_cast<uint64_t>(1000.0 * std::max(fill, double(result.emitted) / double(cap)));
        if (now > shown) progress.add(now - shown), shown = now;
    }
    progress.finish();
    static const char* kNames[3] = {"global", "caustic", "volume"};
    for (int m = 0; m < 3; ++m) {
        if (!maps[m]) continue;
        maps[m]->emitted = full_at[m] ? full_at[m] : result.emitted;
        if (maps[m]->photons.size() < maps[m]->budget)
            result.warnings.push_back(
                std::string(kNames[m]) + " map: " + std::to_string(maps[m]->photons.size()) +
                " of " + std::to_string(maps[m]->budget) + " photons stored after " +
                std::to_string(result.emitted) + " emitted (photons.max_emitted reached)");
    }
    if (result.emitted > 0) result.capped_power /= double(result.emitted);
    if (result.capped_power > 0.001) {
        char text[200];
        std::snprintf(text, sizeof text,
                      "photons.max_bounces = %d cut %llu photon paths carrying %.2g%% of the "
                      "emitted power; raise it (the photon maps miss that light)",
                      settings.max_bounces, static_cast<unsigned long long>(result.capped),
                      100.0 * result.capped_power);
        result.warnings.push_back(text);
    }
    result.time_s = timer.seconds();
    return result;
}

PhotonMaps build_trees(PhotonPassResult&& pass) {
    PhotonMaps maps;
    auto build = [&](std::optional<StoredPhotons>& in, std::optional<PhotonMap>& out) {
        if (!in) return;
        const Timer timer;
        PhotonMap m;
        m.emitted = in->emitted;
        m.photon_power =
            in->emitted > 0 ? pass.total_power / static_cast<float>(in->emitted) : 0.0f;
        in->photons.shrink_to_fit();
        m.tree = KdTree<Photon>(std::move(in->photons));
        m.build_s = timer.seconds();
        out = std::move(m);
    };
    tbb::parallel_invoke([&] { build(pass.global, maps.global); },
                         [&] { build(pass.caustic, maps.caustic); },
                         [&] { build(pass.volume, maps.volume); });
    return maps;
}

}  // namespace fogmap
