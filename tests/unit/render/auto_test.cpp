// auto's pilot (render/pilot.h) on scenes/smoke.json at 64x36: its predictions of the full
// render's relMSE and work against the relMSE measured from full renders and the work they
// count; its pick for thick and thin smoke; its seeds' independence between render seeds; the
// same numbers for any thread count.

#include "render/metrics.h"
#include "render/pilot.h"
#include "render/pipeline.h"
#include "scene/scene.h"
#include "scene/scene_desc_json.h"

#include <gtest/gtest.h>

#include <set>
#include <string>
#include <vector>

namespace fogmap {
namespace {

// smoke.json left to auto at `spp` (64x36 unless said), its σ scaled by `scale`.
SceneDesc small_smoke(int spp, float scale = 1.0f, int width = 64, int height = 36) {
    const std::string s = std::to_string(14.0f * scale), a = std::to_string(1.0f * scale);
    return load_scene_desc(
        FOGMAP_SOURCE_DIR "/scenes/smoke.json",
        {"render.integrator=auto", "camera.width=" + std::to_string(width),
         "camera.height=" + std::to_string(height), "render.spp=" + std::to_string(spp),
         "media.0.sigma_s=[" + s + "," + s + "," + s + "]",
         "media.0.sigma_a=[" + a + "," + a + "," + a + "]"});
}

// `desc` as auto's pilot sees it.
SceneDesc as_piloted(const SceneDesc& desc) { return piloted_desc(desc, resolve_run(desc)); }

// auto's pick for `desc` once its media are loaded.
RunSetup pick(const SceneDesc& desc, bool* piloted = nullptr) {
    return settle_pilot(desc, resolve_run(desc), *load_scene(desc), nullptr, piloted);
}

// relMSE as bench measures it, with d² from pairs of independent renders, (a − b)² / 2, and y
// the mean of every render: the error one render of the pair has.
double pair_rel_mse(const std::vector<std::vector<Image>>& pairs, size_t which) {
    const Image& a = pairs[which][0];
    const Image& b = pairs[which][1];
    double sum = 0.0;
    for (size_t i = 0; i < a.pixels.size(); ++i)
        for (int c = 0; c < 3; ++c) {
            double y = 0.0, n = 0.0;
            for (const auto& p : pairs)
                for (const Image& im : p) y += im.pixels[i][c], n += 1.0;
            y /= n;
            const double d = double(a.pixels[i][c]) - b.pixels[i][c];
            sum += relative_squared_error(0.5 * d * d, y);
        }
    return sum / (3.0 * a.pixels.size());
}

TEST(Pilot, PredictsTheFullRendersErrorAndWork) {
    ASSERT_TRUE(resolve_run(small_smoke(64)).pilot);
    const SceneDesc desc = as_piloted(small_smoke(64));
    const auto scene = load_scene(desc);
    const Pilot pilot = run_pilot(desc, *scene);
    ASSERT_EQ(pilot.candidates.size(), 3u);
    EXPECT_EQ(pilot.tile_count, 1);  // 1 in 2048 / 64 tiles, but 8 of the 12 at least
    EXPECT_EQ(pilot.spp, 4);

    // The photon and path candidates rendered in full, twice each.
    std::vector<std::vector<Image>> pairs(2);
    std::vector<double> work(2, 0.0);
    for (size_t c = 0; c < 2; ++c) {
        const PilotCandidate& cand = pilot.candidates[c];
        for (uint64_t seed = 11; seed <= 12; ++seed) {
            SceneDesc d = desc;
            d.render.integrator = cand.integrator;
            d.render.seed = seed;
            PipelineResult run = run_on_scene(resolve_run(d), *scene);
            const Work w = work_units(run.report);
            work[c] += 0.5 * (w.render + w.photons + w.fixed);
            pairs[c].push_back(std::move(run.film.beauty));
        }
    }
    for (size_t c = 0; c < 2; ++c) {
        const PilotCandidate& cand = pilot.candidates[c];
        const double measured = pair_rel_mse(pairs, c);
        SCOPED_TRACE(to_string(cand.integrator));
        // 1.47x high for photon, 1.12x for path (4 spp lack some of the N-rooks positions of 64;
        // 1.5-1.7x at 1 spp; the first vertex's strata are groups of 4 in both): what the pick
        // rests on is their ratio, below (1.19 predicted against 0.98 measured).
        EXPECT_NEAR(cand.rel_mse / measured, 1.0, 0.5) << cand.rel_mse << " vs " << measured;
        EXPECT_NEAR(cand.work / work[c], 1.0, 0.15) << cand.work << " vs " << work[c];
    }
    // What the pick rests on: the ratio of the scores.
    const double predicted = pilot.candidates[0].score() / pilot.candidates[1].score();
    const double measured = pair_rel_mse(pairs, 0) * work[0] / (pair_rel_mse(pairs, 1) * work[1]);
    EXPECT_NEAR(predicted / measured, 1.0, 0.25) << predicted << " vs " << measured;
}

// At smoke.json's bench size (240x135; at 64x36 the two come out even since the first vertex's
// samples are stratified: relMSE x work measured 0.98 of the path tracer's).
TEST(Pilot, ThickSmokeGoesToThePhotonMapsThinSmokeToThePathTracer) {
    for (const float scale : {1.0f, 0.03f}) {
        const RunSetup picked = pick(small_smoke(64, scale, 240, 135));
        EXPECT_EQ(picked.run.render.integrator,
                  scale == 1.0f ? Integrator::Photon : Integrator::Path)
            << picked.reason;
        EXPECT_NE(picked.reason.find("a pilot (1 in 16 tiles, 4 spp, two seeds)"),
                  std::string::npos)
            << picked.reason;
    }
    SceneDesc progressive = small_smoke(64, 0.03f);  // the others have no iterations
    progressive.progressive.iterations = 4;
    const RunSetup kept = pick(progressive);
    EXPECT_EQ(kept.run.render.integrator, Integrator::Photon);
    EXPECT_NE(kept.reason.find("progressive iterations"), std::string::npos);
    SceneDesc named = small_smoke(64, 0.03f);  // a scene that names its integrator keeps it
    named.render.integrator = Integrator::Photon;
    EXPECT_EQ(pick(named).run.render.integrator, Integrator::Photon);
}

// kPilotMaxShare: at 8 spp the pilot's 4 would be half the render's samples per pixel (its
// photon runs tracing twice the render's photons), and at 32 an eighth (half of them): photon
// without a pilot, saying why.
// kPilotMaxSamples: at 64 spp on a 64 x 36 image (every one of its 12 tiles in the pilot: at
// least 8) the pilot's six images would take 6 x 4 / 64 of the render's camera samples: photon
// without one, saying why; at 512 spp, 6 x 4 / 512 (4.7%), the pilot runs.
TEST(Pilot, RendersOfFewSamplesTakeThePhotonMapsWithoutAPilot) {
    const SceneDesc few = small_smoke(8, 0.03f);  // thin: the pilot would pick path at 64 spp
    EXPECT_GT(pilot_share(few).spp, kPilotMaxShare * few.render.spp);
    bool piloted = true;
    const RunSetup picked = pick(few, &piloted);
    EXPECT_FALSE(piloted);
    EXPECT_EQ(picked.run.render.integrator, Integrator::Photon);
    EXPECT_NE(picked.reason.find("8 spp, where a pilot (4 spp, its photon runs tracing a "
                                 "quarter of the render's photons or more) would cost more "
                                 "than it saves: photon without one"),
              std::string::npos)
        << picked.reason;
    const SceneDesc eighth = small_smoke(32, 0.03f);
    EXPECT_GT(pilot_share(eighth).spp, kPilotMaxShare * eighth.render.spp);
    EXPECT_NE(
        decline_pilot(eighth, resolve_run(eighth)).reason.find("32 spp, where a pilot (4 spp"),
        std::string::npos);
    const SceneDesc small = small_smoke(64, 0.03f);
    EXPECT_EQ(pilot_share(small).spp, 4);
    EXPECT_DOUBLE_EQ(pilot_samples_share(small, pilot_share(small)), 0.375);
    const RunSetup small_pick = pick(small, &piloted);
    EXPECT_FALSE(piloted);
    EXPECT_NE(small_pick.reason.find("a render of 64 x 36 x 64 spp, whose pilot would take 38% of "
                                     "its camera samples: photon without one"),
              std::string::npos)
        << small_pick.reason;
    // A dry run, without a scene, says the same (decline_pilot).
    const RunSetup declined = decline_pilot(small, resolve_run(small));
    EXPECT_FALSE(declined.pilot);
    EXPECT_EQ(declined.reason, small_pick.reason);
    const SceneDesc more = small_smoke(512, 0.03f);
    EXPECT_TRUE(decline_pilot(more, resolve_run(more)).pilot);
    EXPECT_DOUBLE_EQ(pilot_samples_share(more, pilot_share(more)), 6.0 * 4.0 / 512.0);
    EXPECT_NE(pick(more, &piloted).reason.find("a pilot (1 in"), std::string::npos);
    EXPECT_TRUE(piloted);
    // The report times a pilot only where one ran.
    const auto has_pilot_phase = [](const SceneDesc& desc) {
        for (const auto& [name, s] : run_pipeline(desc, true).report.phases_s)
            if (name == "pilot") return true;
        return false;
    };
    EXPECT_FALSE(has_pilot_phase(few));
    EXPECT_FALSE(has_pilot_phase(small));
    EXPECT_TRUE(has_pilot_phase(more));
}

// Render seeds 2j and 2j + 1 (the pair the xor derivation gave the same pilot seeds, swapped),
// for 500 j: each pair's two seeds differ, and no pilot seed is another seed's (brute force).
TEST(Pilot, NeighbouringRenderSeedsGetDisjointPilotSeeds) {
    for (uint64_t j = 0; j < 500; ++j) {
        const uint64_t a[2] = {pilot_seed(2 * j, 0), pilot_seed(2 * j, 1)};
        const uint64_t b[2] = {pilot_seed(2 * j + 1, 0), pilot_seed(2 * j + 1, 1)};
        EXPECT_NE(a[0], a[1]) << j;
        EXPECT_NE(b[0], b[1]) << j;
        for (const uint64_t x : a)
            for (const uint64_t y : b)
                EXPECT_NE(x, y) << "render seeds " << 2 * j << ", " << 2 * j + 1;
    }
    std::set<uint64_t> seen;
    for (uint64_t seed = 0; seed < 1000; ++seed)
        for (const int k : {0, 1}) EXPECT_TRUE(seen.insert(pilot_seed(seed, k)).second) << seed;
}

TEST(Pilot, TheSameNumbersForAnyThreadCount) {
    std::vector<Pilot> pilots;
    for (const int threads : {1, 2}) {
        SceneDesc desc = as_piloted(small_smoke(16, 1.0f, 160, 90));
        desc.render.threads = threads;
        pilots.push_back(run_pilot(desc, *load_scene(desc)));
    }
    EXPECT_EQ(pilots[0].tile_count, 7);  // 1 in 2048 / 16 tiles, but 8 of the 60 at least
    ASSERT_EQ(pilots[0].candidates.size(), pilots[1].candidates.size());
    for (size_t c = 0; c < pilots[0].candidates.size(); ++c) {
        EXPECT_EQ(pilots[0].candidates[c].rel_mse, pilots[1].candidates[c].rel_mse);
        EXPECT_EQ(pilots[0].candidates[c].work, pilots[1].candidates[c].work);
    }
    EXPECT_EQ(pilots[0].best, pilots[1].best);
}

}  // namespace
}  // namespace fogmap
