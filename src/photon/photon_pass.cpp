#include "photon/photon_pass.h"

#include "core/progress.h"
#include "core/ranks.h"
#include "core/sampling.h"
#include "core/timer.h"
#include "core/world_range.h"
#include "media/phase.h"
#include "media/ray_march.h"
#include "photon/streams.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <type_traits>

namespace fogmap {

namespace {

constexpr uint64_t kBatch = 1u << 15;  // attempts of the fastest stream per round
constexpr uint64_t kChunk = 512;
constexpr uint64_t kPilot = 8192;      // attempts per stream before the allocation
constexpr uint64_t kFirstRound = 256;  // the pilot's first round, kept whole by every map
constexpr double kGlobalShare = 0.25;  // see close_global_with_volume in trace_photons

constexpr int kGlobal = static_cast<int>(PhotonMapId::Global);
constexpr int kCaustic = static_cast<int>(PhotonMapId::Caustic);
constexpr int kVolume = static_cast<int>(PhotonMapId::Volume);

}  // namespace

PhotonTracer::PhotonTracer(const Scene& scene, const MarchSettings& march, int max_bounces)
    : scene_(scene),
      marcher_(scene.media, march),
      method_(march.method),
      max_bounces_(max_bounces) {
    for (const Medium& m : scene.media) media_bounds_.extend(m.world_bounds());
}

TracedPath PhotonTracer::trace(Ray ray, Color power, Rng& rng,
                               std::vector<Medium::Sampler>& samplers, uint32_t index,
                               std::vector<TaggedPhoton>* out, PhotonSource source,
                               std::vector<TaggedBeam>* beams) const {
    const Scene& scene = scene_;
    // A bounce-stream photon has had its interaction (the surface it leaves) and stores volume
    // photons only; a sun or sky path whose next segment after a first, diffuse, interaction
    // belongs to the bounce stream stores no volume photons (photon/streams.h).
    const bool bounce = source == PhotonSource::Bounce;
    const std::array<bool, 3> store =
        bounce ? std::array<bool, 3>{false, false, store_[kVolume]} : store_;
    bool owned = false;
    auto deposit = [&](int map, const Photon& photon) {
        out->push_back({index, static_cast<PhotonMapId>(map), photon});
    };
    // The part of a segment (ray on [0, end)) within the media's bounds, as a beam.
    auto leave_beam = [&](float end) {
        float enter, leave;
        if (intersect_box(media_bounds_, ray, 0.0f, end, &enter, &leave) && leave > enter)
            beams->push_back({index, PhotonBeam(ray.at(enter), ray.at(leave), power)});
    };
    const bool with_beams = beams_ && beams;
    bool met_media = false;
    auto ended = [&](PathEnd end, int depth) {
        return TracedPath{end, ray, power, depth, met_media};
    };
    // Emission photons have no shadow rays to leave their first interaction to.
    const int stored_from = source == PhotonSource::Emission ? 0 : 1;
    bool specular_chain = true;  // every interaction so far was specular
    const bool has_media = !samplers.empty();
    const int max_bounces = max_bounces_;
    for (int depth = bounce ? 1 : 0; depth < max_bounces; ++depth) {
        std::optional<SurfaceHit> hit;
        float t_max = kInfinity;
        if (scene.surfaces) {
            hit = scene.surfaces->intersect(ray, 0.0f, kInfinity);
            if (hit) t_max = hit->t;
        }
        if (has_media) {
            float enter, leave;
            met_media =
                met_media || (!media_bounds_.empty() &&
                              intersect_box(media_bounds_, ray, 0.0f, t_max, &enter, &leave));
            bool scattered = false;
            Vec3 x;
            const bool volume_store = depth >= stored_from && store[kVolume] && !owned;
            if (method_ == FreePathMethod::March) {
                const RayMarcher::FreePath fp =
                    marcher_.sample_free_path(samplers, ray, t_max, rng);
                if (with_beams && volume_store) leave_beam(fp.collided ? fp.t : t_max);
                power *= fp.weight;
                if (fp.collided) {
                    x = fp.x;
                    // Russian roulette on the albedo; power changes only by channel ratios.
                    // Only scattering events are stored (absorptions would count σ_t, not σ_s).
                    const double p = (double(fp.sigma_s.x) + fp.sigma_s.y + fp.sigma_s.z) /
                                     (double(fp.sigma_t.x) + fp.sigma_t.y + fp.sigma_t.z);
                    if (rng.uniform() >= p) return ended(PathEnd::Absorbed, depth + 1);
                    power *= fp.sigma_s / (fp.sigma_t * static_cast<float>(p));
                    if (volume_store) deposit(kVolume, Photon(x, ray.d, power));
                    scattered = true;
                }
            } else {
                Color beta(1.0f);
                const TrackResult tr = delta_track(samplers, ray, t_max, rng, &beta);
                if (with_beams && volume_store)
                    leave_beam(tr.event == TrackEvent::Escaped ? t_max : tr.t);
                power *= beta;
                if (tr.event == TrackEvent::Absorbed) return ended(PathEnd::Absorbed, depth + 1);
                if (tr.event == TrackEvent::Scattered) {
                    x = ray.at(tr.t);
                    if (volume_store) deposit(kVolume, Photon(x, ray.d, power));
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
        if (depth >= stored_from) {
            // Surface photons keep the normal of the side they arrived on (Lambertian surfaces
            // need no direction; see photon.h). L S+ D: specular bounces only, at least one.
            const bool caustic = specular_chain && depth > 0;
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
        if (depth == 0 && bounce_owner_ && source == PhotonSource::SunOrSky)
            owned = bounce_owner_->owns_bounce(scene, ray);
    }
    return ended(PathEnd::BounceCap, max_bounces);
}

namespace {

/// What one chunk of one stream's attempts produced.
struct ChunkOut {
    std::vector<TaggedPhoton> photons;
    std::vector<TaggedBeam> beams;
    uint64_t accepted = 0;      ///< attempts that yielded a photon
    uint64_t met_media = 0;     ///< photon paths that entered the media's bounds
    uint64_t interactions = 0;  ///< the work traced (a deterministic cost measure)
    uint64_t longest = 0;       ///< the most interactions of one path
    uint64_t steps = 0;         ///< medium density evaluations and tentative collisions
    uint64_t capped = 0;
    double capped_power = 0.0;  ///< Σ average(relative power) of paths the bounce limit cut
};

/// A chunk's output as bytes, for the ranks sharing a pass (the same machine's layout on every
/// rank: the ranks of one job run one build).
template <class T>
void put(std::vector<uint8_t>* bytes, const T* values, size_t n) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* p = reinterpret_cast<const uint8_t*>(values);
    bytes->insert(bytes->end(), p, p + n * sizeof(T));
}

void put_chunk(std::vector<uint8_t>* bytes, const ChunkOut& o) {
    const uint64_t n = o.photons.size(), nb = o.beams.size();
    const uint64_t counts[] = {o.accepted, o.met_media, o.interactions, o.longest, o.capped,
                               n,          nb,          o.steps};
    put(bytes, counts, 8);
    put(bytes, &o.capped_power, 1);
    put(bytes, o.photons.data(), n);
    put(bytes, o.beams.data(), nb);
}

/// Reads back what put_chunk wrote, advancing *at.
ChunkOut get_chunk(const uint8_t** at) {
    auto get = [at](auto* values, size_t n) {
        std::memcpy(values, *at, n * sizeof(*values));
        *at += n * sizeof(*values);
    };
    uint64_t counts[8];
    get(counts, 8);
    ChunkOut o;
    o.accepted = counts[0];
    o.met_media = counts[1];
    o.interactions = counts[2];
    o.longest = counts[3];
    o.capped = counts[4];
    o.steps = counts[7];
    get(&o.capped_power, 1);
    o.photons.resize(counts[5]);
    get(o.photons.data(), o.photons.size());
    o.beams.resize(counts[6]);
    get(o.beams.data(), o.beams.size());
    return o;
}

/// Per (map, stream): photons stored, their summed relative power, and, once closed, the
/// attempt count at which the map stopped taking that stream's photons.
struct Pair {
    uint64_t stored = 0;
    double power = 0.0;
    bool closed = false;
    uint64_t stop_at = 0;
};

}  // namespace

PhotonPassResult trace_photons(const Scene& scene, const Plan& plan, const PhotonSettings& settings,
                               const MarchSettings& march, uint64_t seed, bool quiet,
                               Ranks* ranks) {
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

    const StreamSet set = make_streams(scene, maps[kCaustic] != nullptr, maps[kVolume] != nullptr);
    for (const Light& l : scene.lights) result.total_power += average(light_power(l, scene.bounds));
    result.total_power += static_cast<float>(emitted_power(scene));
    if (set.streams.empty()) {
        result.warnings.push_back("no light emits power: no photons traced");
        return result;
    }
    const size_t n_streams = set.streams.size();
    // Ranks sharing the pass trace every n_ranks-th chunk of each round (the chunk count does
    // not depend on the rank count) and exchange them before the merge.
    const size_t n_ranks = ranks ? size_t(ranks->size()) : 1, my_rank = ranks ? ranks->rank() : 0;
    MarchSettings free_paths = march;
    if (settings.volume_beams) free_paths.method = FreePathMethod::Delta;
    PhotonTracer tracer(scene, free_paths, settings.max_bounces);
    tracer.set_bounce_owner(&set);
    tracer.set_beams(settings.volume_beams && maps[kVolume]);
    std::array<bool, 3> open;  // maps still taking photons
    for (int m = 0; m < 3; ++m) open[m] = maps[m] && maps[m]->budget > 0;
    tracer.set_store(open);

    std::vector<uint64_t> attempts(n_streams, 0), interactions(n_streams, 0);
    std::vector<StreamReport>& streams = result.streams;
    streams.resize(n_streams);
    for (size_t s = 0; s < n_streams; ++s) streams[s].name = set.streams[s].name;
    std::vector<std::array<Pair, 3>> pairs(n_streams);
    std::array<std::vector<uint16_t>, 3> photon_stream;  // each stored photon's stream
    std::vector<uint16_t> beam_stream;                   // each stored beam's stream

    // Closes map m at every stream's attempts so far (its photons weigh Φ_s over those).
    auto close_now = [&](int m) {
        open[m] = false;
        for (size_t u = 0; u < n_streams; ++u) {
            pairs[u][m].closed = true;
            pairs[u][m].stop_at = attempts[u];
        }
    };

    // Emits count[s] more attempts of every stream in parallel chunks and merges them in a fixed
    // order, stream by stream and attempt by attempt. A map closes at the attempt whose path fills
    // its budget (keeping that whole path): for that stream at that attempt, for the streams
    // merged before it at the end of this round, for those after it at its start. Not during the
    // first round, though, which every map keeps whole: every stream must have attempts behind
    // every map, or the sum over streams would miss what a stream could have brought.
    auto emit = [&](const std::vector<uint64_t>& count) {
        const bool first = attempts[0] == 0;
        struct Job {
            size_t stream;
            uint64_t begin, end;
        };
        std::vector<Job> jobs;
        for (size_t s = 0; s < n_streams; ++s)
            for (uint64_t b = 0; b < count[s]; b += kChunk)
                jobs.push_back({s, attempts[s] + b, attempts[s] + std::min(count[s], b + kChunk)});
        std::vector<ChunkOut> out(jobs.size());
        tbb::parallel_for(tbb::blocked_range<size_t>(0, jobs.size(), 1), [&](const auto& r) {
            std::vector<Medium::Sampler> samplers;
            for (const Medium& m : scene.media) samplers.emplace_back(m);
            for (size_t j = r.begin(); j != r.end(); ++j) {
                if (j % n_ranks != my_rank) continue;  // another rank's chunk
                const Job& job = jobs[j];
                const PhotonStream& st = set.streams[job.stream];
                ChunkOut& o = out[j];
                uint64_t steps_before = 0;
                for (const Medium::Sampler& m : samplers) steps_before += m.steps();
                for (uint64_t i = job.begin; i < job.end; ++i) {
                    Rng rng(seed, i, st.key);
                    Ray ray;
                    Color power = st.color;
                    const int s = static_cast<int>(job.stream);
                    PhotonSource source;
                    bool sampled;
                    if (s == set.bounce) {
                        source = PhotonSource::Bounce;
                        sampled = sample_bounce(set, s, scene, samplers, rng, &ray, &power);
                    } else if (st.medium >= 0) {
                        source = PhotonSource::Emission;
                        sampled = sample_emission_stream(set, s, samplers, rng, &ray, &power);
                    } else {
                        source = scene.lights[st.light].is_infinite() ? PhotonSource::SunOrSky
                                                                      : PhotonSource::LocalLight;
                        sampled = sample_stream(set, s, scene, rng, &ray);
                    }
                    if (!sampled) continue;
                    ++o.accepted;
                    const TracedPath path = tracer.trace(ray, power, rng, samplers,
                                                         static_cast<uint32_t>(i - job.begin),
                                                         &o.photons, source, &o.beams);
                    o.met_media += path.met_media ? 1 : 0;
                    o.interactions += static_cast<uint64_t>(path.interactions);
                    o.longest = std::max<uint64_t>(o.longest, path.interactions);
                    if (path.end == PathEnd::BounceCap) {
                        ++o.capped;
                        o.capped_power += average(path.power);
                    }
                }
                for (const Medium::Sampler& m : samplers) o.steps += m.steps();
                o.steps -= steps_before;
            }
        });
        if (n_ranks > 1) {  // every rank gets every chunk, and all merge them alike
            const Timer exchange;
            std::vector<uint8_t> mine;
            for (size_t j = my_rank; j < jobs.size(); j += n_ranks) put_chunk(&mine, out[j]);
            const std::vector<std::vector<uint8_t>> all = ranks->all_gather(mine);
            for (size_t q = 0; q < n_ranks; ++q) {
                const uint8_t* at = all[q].data();
                for (size_t j = q; j < jobs.size(); j += n_ranks) out[j] = get_chunk(&at);
            }
            result.exchange_s += exchange.seconds();
        }
        for (size_t j = 0; j < jobs.size(); ++j) {
            const Job& job = jobs[j];
            const size_t s = job.stream;
            StreamReport& sr = streams[s];
            sr.photons += out[j].accepted;
            sr.met_media += out[j].met_media;
            sr.capped += out[j].capped;
            sr.capped_power += out[j].capped_power;
            sr.longest = std::max(sr.longest, out[j].longest);
            interactions[s] += out[j].interactions;
            result.steps += out[j].steps;
            result.interactions += out[j].interactions;
            for (const TaggedPhoton& t : out[j].photons) {
                const int m = static_cast<int>(t.map);
                Pair& p = pairs[s][m];
                const uint64_t e = job.begin + t.index;
                if (p.closed && e >= p.stop_at) continue;
                maps[m]->photons.push_back(t.photon);
                photon_stream[m].push_back(static_cast<uint16_t>(s));
                ++p.stored;
                p.power += average(t.photon.power());
                if (!first && open[m] && maps[m]->photons.size() >= maps[m]->budget) {
                    open[m] = false;
                    for (size_t u = 0; u < n_streams; ++u) {
                        pairs[u][m].closed = true;
                        pairs[u][m].stop_at = u < s    ? attempts[u] + count[u]
                                              : u == s ? e + 1
                                                       : attempts[u];
                    }
                }
            }
            // Beams go with the volume map's photons: those of the attempts it still takes.
            for (const TaggedBeam& t : out[j].beams) {
                const Pair& p = pairs[s][kVolume];
                if (p.closed && job.begin + t.index >= p.stop_at) continue;
                maps[kVolume]->beams.push_back(t.beam);
                beam_stream.push_back(static_cast<uint16_t>(s));
            }
        }
        for (size_t s = 0; s < n_streams; ++s) attempts[s] += count[s];
        for (int m = 0; m < 3 && first; ++m)
            if (open[m] && maps[m]->photons.size() >= maps[m]->budget) close_now(m);
        tracer.set_store(open);
    };
    auto total_attempts = [&] {
        uint64_t n = 0;
        for (uint64_t a : attempts) n += a;
        return n;
    };
    auto any_open = [&] { return open[0] || open[1] || open[2]; };
    // Attempts behind a pair's photons: all of the stream's, or those before the map closed.
    auto behind = [&](size_t s, int m) {
        return double(pairs[s][m].closed ? pairs[s][m].stop_at : attempts[s]);
    };

    uint64_t cap = settings.max_emitted > 0 ? settings.max_emitted : 100 * largest;
    // The volume map alone closes at settings.volume_attempts (photon_pass.h).
    const bool volume_rule = settings.volume_attempts > 0 && open[kVolume] && !open[kGlobal] &&
                             !open[kCaustic] && settings.volume_attempts < cap;
    if (volume_rule) cap = settings.volume_attempts;
    Progress progress("photons", 1000, quiet);

    // Pilot: rounds of kFirstRound, twice that, ... attempts of every stream, kPilot in all, or
    // less when the cap or the budgets are reached first.
    for (uint64_t n = kFirstRound; any_open();) {
        const uint64_t left = cap > total_attempts() ? (cap - total_attempts()) / n_streams : 0;
        const uint64_t done = attempts[0];
        const uint64_t round = std::min({n, kPilot - done, left});
        if (round == 0) break;
        emit(std::vector<uint64_t>(n_streams, round));
        n *= 2;
    }

    // Allocation over the maps still open (variance per unit of work, summed over their relative
    // variances): a map's variance is about Σ_s W_s P_ms, W_s = Φ_s / N_s the power of one photon
    // of stream s and P_ms the power stream s deposits in map m; minimising Σ_m Var_m / P_m² for a
    // total cost Σ_s N_s c_s gives N_s ∝ sqrt(Φ_s Σ_m (P_ms / P_m²) / c_s), c_s = 1 + interactions
    // per attempt, P_ms estimated from every photon so far and recomputed every round. Every
    // stream keeps at least 5% of its share under plain emission (∝ Φ_s), so light the pilot saw
    // little of is still sampled.
    double max_power = 0.0;
    for (const PhotonStream& st : set.streams) max_power = std::max(max_power, st.region_power);
    // Power (W, channel average) stream s has put into map m per attempt, × its region's power.
    auto deposit_rate = [&](size_t s, int m) {
        return set.streams[s].region_power * pairs[s][m].power / behind(s, m);
    };
    auto allocation = [&] {
        std::vector<std::array<double, 3>> deposited(n_streams);
        std::array<double, 3> map_power{0.0, 0.0, 0.0};
        for (size_t s = 0; s < n_streams; ++s)
            for (int m = 0; m < 3; ++m) {
                deposited[s][m] = deposit_rate(s, m);
                map_power[m] += deposited[s][m];
            }
        std::vector<double> rate(n_streams, 0.0);
        double max_rate = 0.0;
        for (size_t s = 0; s < n_streams; ++s) {
            double g = 0.0;
            for (int m = 0; m < 3; ++m)
                if (open[m] && map_power[m] > 0.0)
                    g += deposited[s][m] / (map_power[m] * map_power[m]);
            const double cost =
                1.0 + double(interactions[s]) / double(std::max<uint64_t>(1, attempts[s]));
            rate[s] = std::sqrt(set.streams[s].region_power * g / cost);
            max_rate = std::max(max_rate, rate[s]);
        }
        for (size_t s = 0; s < n_streams; ++s)
            rate[s] = std::max(max_rate > 0.0 ? rate[s] / max_rate : 0.0,
                               0.05 * set.streams[s].region_power / max_power);
        return rate;
    };

    // A global map still open when the volume map is full closes with it if its photons carry
    // under kGlobalShare of the volume map's power: light that surfaces get only through the media
    // (an open ground under smoke) would otherwise drive the whole pass — smoke1 over a 10 km
    // ground: 4.4M attempts for the global map against 2.75M for the volume map; closing with it
    // took the render from 3.9 to 3.1 s at the same relMSE. Unbiased: its photons weigh Φ_s over
    // the attempts at its close. Checked once, when the volume map has filled.
    bool global_checked = false;
    auto close_global_with_volume = [&] {
        if (global_checked || !maps[kGlobal] || !maps[kVolume] || open[kVolume] || !open[kGlobal])
            return;
        global_checked = true;
        double global_power = 0.0, volume_power = 0.0;
        for (size_t s = 0; s < n_streams; ++s) {
            global_power += deposit_rate(s, kGlobal);
            volume_power += deposit_rate(s, kVolume);
        }
        if (!(global_power < kGlobalShare * volume_power)) return;
        close_now(kGlobal);
        tracer.set_store(open);
        char text[160];
        std::snprintf(text, sizeof text,
                      "closed with the volume map: its photons carry %.0f%% of the volume map's "
                      "power",
                      100.0 * global_power / volume_power);
        maps[kGlobal]->stopped = text;
    };

    // Rounds of the allocation until every map is full or the cap is reached.
    uint64_t shown = 0;
    while (any_open()) {
        close_global_with_volume();
        if (!any_open()) break;
        const std::vector<double> rate = allocation();
        const uint64_t left = cap > total_attempts() ? cap - total_attempts() : 0;
        if (left == 0) break;
        std::vector<uint64_t> count(n_streams, 0);
        uint64_t planned = 0;
        for (size_t s = 0; s < n_streams; ++s)
            planned += count[s] = static_cast<uint64_t>(std::ceil(kBatch * rate[s]));
        if (planned > left) {  // the last round: what the cap leaves, in the same proportions
            uint64_t scaled = 0;
            for (uint64_t& c : count) scaled += c = c * left / planned;
            if (scaled == 0) count[0] = left;
        }
        emit(count);
        double fill = 1.0;
        for (int m = 0; m < 3; ++m)
            if (maps[m] && maps[m]->budget > 0)
                fill = std::min(fill, double(maps[m]->photons.size()) / double(maps[m]->budget));
        const uint64_t now = static_cast<uint64_t>(
            1000.0 * std::min(1.0, std::max(fill, double(total_attempts()) / double(cap))));
        if (now > shown) progress.add(now - shown), shown = now;
    }
    progress.finish();

    // Weights: a photon of stream s in map m carries Φ_s / N_ms, N_ms the attempts of s when m
    // stopped taking its photons; the map's photon power is the largest and each photon's
    // relative power is rescaled to it.
    result.emitted = total_attempts();
    static const char* kNames[3] = {"global", "caustic", "volume"};
    for (int m = 0; m < 3; ++m) {
        if (!maps[m]) continue;
        StoredPhotons& map = *maps[m];
        std::vector<double> weight(n_streams, 0.0);
        for (size_t s = 0; s < n_streams; ++s) {
            map.emitted += static_cast<uint64_t>(behind(s, m));
            weight[s] = set.streams[s].region_power / std::max(1.0, behind(s, m));
            map.photon_power = std::max(map.photon_power, static_cast<float>(weight[s]));
            streams[s].stored[m] = pairs[s][m].stored;
        }
        // Photons and beams alike: each record's power rescaled to its stream's weight.
        auto reweigh = [&](auto& records, const std::vector<uint16_t>& stream_of) {
            for (size_t i = 0; i < records.size(); ++i) {
                const double w = weight[stream_of[i]] / map.photon_power;
                if (w != 1.0)
                    records[i].power_rgbe = encode_rgbe(records[i].power() * static_cast<float>(w));
            }
        };
        reweigh(map.photons, photon_stream[m]);
        reweigh(map.beams, beam_stream);
        if (m == kVolume && volume_rule && map.photons.size() < map.budget)
            map.stopped = "closed after " + std::to_string(result.emitted) + " attempts (" +
                          g_text(kVolumeAttemptsPerSample) +
                          " per camera sample, at least its budget)";
        if (map.photons.size() < map.budget && map.stopped.empty())
            result.warnings.push_back(
                std::string(kNames[m]) + " map: " + std::to_string(map.photons.size()) + " of " +
                std::to_string(map.budget) + " photons stored after " +
                std::to_string(result.emitted) + " emitted (photons.max_emitted reached)");
    }
    double capped_power = 0.0;
    for (size_t s = 0; s < n_streams; ++s) {
        streams[s].attempts = attempts[s];
        result.capped += streams[s].capped;
        capped_power += streams[s].capped_power * set.streams[s].region_power /
                        double(std::max<uint64_t>(1, attempts[s]));
    }
    result.capped_power = result.total_power > 0.0f ? capped_power / result.total_power : 0.0;
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
        m.photon_power = in->photon_power;
        m.stopped = std::move(in->stopped);
        m.beams = std::move(in->beams);
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
