// Progressive photon mapping (Knaus and Zwicker 2011): the radius sequence follows
// r²_{i+1} = r²_i (i+α)/(i+1) (surfaces) and r³_{i+1} = r³_i (i+α)/(i+1) (volumes), the error
// against a path-traced reference falls over the iterations on smoke.json, the photon memory
// of an iteration does not grow with the iteration count, and an iteration takes the samples of
// the iteration-size rule, its volume map's photons following them.

#include "render/gather_params.h"
#include "render/metrics.h"
#include "render/pipeline.h"
#include "render/run_setup.h"
#include "scene/scene_desc_json.h"

#include <gtest/gtest.h>

#include <cmath>

namespace fogmap {
namespace {

TEST(Progressive, RadiusSequenceFollowsKnausZwicker) {
    const double alpha = 0.7, r1 = 0.5;
    double product = 1.0;  // Π_{j=1}^{i-1} (j+α)/(j+1)
    for (int i = 1; i < 50; ++i) {
        const float r2 = progressive_radius(static_cast<float>(r1), i + 1, float(alpha), 2);
        const float r3 = progressive_radius(static_cast<float>(r1), i + 1, float(alpha), 3);
        product *= (i + alpha) / (i + 1.0);
        EXPECT_NEAR(r2 * r2, r1 * r1 * product, 1e-5 * r1 * r1) << "iteration " << i + 1;
        EXPECT_NEAR(double(r3) * r3 * r3, r1 * r1 * r1 * product, 1e-5 * r1 * r1 * r1);
    }
}

// The radii the run loop actually gathers with (the report's, per iteration) follow the schedule's
// definition: r_i^d = r_1^d Π_{j<i} (j + α)/(j + 1) with d = 3 for the volume map and d = 2 for
// the surface maps (a volume radius shrunk with the surface exponent would fail here).
TEST(Progressive, RunLoopShrinksVolumeRadiiAsCubesAndSurfaceRadiiAsSquares) {
    const std::string path = std::string(FOGMAP_SOURCE_DIR) + "/scenes/fog.json";
    const double alpha = 0.6;
    const Report r =
        run_pipeline(load_scene_desc(path, {"camera.width=16", "camera.height=9", "render.spp=1",
                                            "photons.volume=2000", "photons.global=2000",
                                            "progressive.iterations=6", "progressive.alpha=0.6"}),
                     true)
            .report;
    ASSERT_EQ(r.iterations.size(), 6u);
    const IterationReport::Radii first = r.iterations[0].radii;
    ASSERT_GT(first.volume, 0.0f);
    ASSERT_GT(first.global, 0.0f);
    double product = 1.0;
    for (size_t i = 1; i < r.iterations.size(); ++i) {
        product *= (i + alpha) / (i + 1.0);
        const IterationReport::Radii& ri = r.iterations[i].radii;
        EXPECT_NEAR(std::pow(ri.volume / first.volume, 3.0), product, 1e-5)
            << "iteration " << i + 1;
        EXPECT_NEAR(std::pow(ri.global / first.global, 2.0), product, 1e-5)
            << "iteration " << i + 1;
        EXPECT_NEAR(std::pow(ri.caustic / first.caustic, 2.0), product, 1e-5);
    }
}

TEST(Progressive, ErrorFallsOverIterationsAndMemoryStaysWithinOneIterationsBudgets) {
    const std::string path = std::string(FOGMAP_SOURCE_DIR) + "/scenes/smoke.json";
    const std::vector<std::string> size{"camera.width=64", "camera.height=36"};
    std::vector<std::string> ref = size;
    ref.push_back("render.integrator=\"path\"");
    ref.push_back("render.spp=2048");
    const Image reference = run_pipeline(load_scene_desc(path, ref), true).film.beauty;

    std::vector<std::string> o = size;
    o.push_back("render.spp=2");
    o.push_back("photons.volume=20000");
    o.push_back("photons.global=5000");
    o.push_back("progressive.iterations=8");
    const Report r = run_pipeline(load_scene_desc(path, o), true, &reference).report;
    ASSERT_EQ(r.iterations.size(), 8u);
    // Each iteration's image is independent, so the running mean's variance falls like 1/i
    // while the shrinking radius lowers the bias: compare iterations 1, 2, 4 and 8.
    for (int i : {1, 3, 7})
        EXPECT_LT(r.iterations[i].rel_mse, r.iterations[i / 2].rel_mse) << "iteration " << i + 1;
    EXPECT_LT(r.iterations[7].rel_mse, 0.5 * r.iterations[0].rel_mse);
    // Memory is one iteration's maps: at most the budgets (20 000 + 5 000 photons of 20 bytes,
    // +1% for the paths that overfill a map), whatever the iteration; the global map may close
    // below its budget with the volume map (photon/photon_pass.h), so it need not be the same.
    const size_t budget_bytes = (20000 + 5000) * 20;
    for (const IterationReport& it : r.iterations) {
        EXPECT_GT(it.photon_bytes, 0u);
        EXPECT_LE(it.photon_bytes, budget_bytes + budget_bytes / 100) << "iteration " << it.index;
        EXPECT_LT(it.radii.volume, r.iterations[0].radii.volume * 1.0001f);
    }
}

// cloud.json at 32 x 18 and 16 spp: 9 216 camera samples a pass, far below the rule's 2^20; its
// volume map's budget is the attempts rule's. One iteration renders the rule's samples (the
// least multiple of 16 at or above 2^20 / 576 a pixel) and its map fills to a photon per attempt,
// a quarter of those samples; advanced.iteration_spp given is the iteration's size, and its map the
// budget's floor.
TEST(Progressive, IterationsTakeTheRulesSamplesAndTheMapFollowsThem) {
    const std::string path = std::string(FOGMAP_SOURCE_DIR) + "/scenes/cloud.json";
    std::vector<std::string> o{"camera.width=32", "camera.height=18", "render.spp=16",
                               "progressive.iterations=1"};
    const uint64_t pixels = 32 * 18;
    const int spp = 16 * int((kIterationSamples + pixels * 16 - 1) / (pixels * 16));  // 1824
    const Report r = run_pipeline(load_scene_desc(path, o), true).report;
    EXPECT_EQ(r.spp, spp);
    ASSERT_EQ(r.maps.size(), 1u);
    EXPECT_EQ(r.maps[0].name, "volume");
    EXPECT_GE(double(r.maps[0].stored), kVolumeAttemptsPerSample * double(spp) * double(pixels));
    EXPECT_NE(r.plan_text.find("iterations of " + std::to_string(spp) + " spp"), std::string::npos)
        << r.plan_text;

    o.push_back("advanced.iteration_spp=8");
    o.push_back("progressive.iterations=2");
    const Report given = run_pipeline(load_scene_desc(path, o), true).report;
    EXPECT_EQ(given.spp, 16);  // two iterations of 8
    ASSERT_EQ(given.maps.size(), 1u);
    // 1 152 attempts by the samples: the budget's floor, photons.volume's default 100 000
    EXPECT_LT(double(given.maps[0].stored), 0.5 * double(r.maps[0].stored));
}

// A plain render of cloud.json at 32 x 18 and 4096 spp (2 359 296 camera samples, its volume
// map's budget the attempts rule's) runs as floor(samples / 2^20) = 2 progressive iterations of
// 2048 spp, with the radius of the second shrunk by Knaus and Zwicker's schedule.
TEST(Progressive, PlainRendersOfManySamplesRunAsIterations) {
    const std::string path = std::string(FOGMAP_SOURCE_DIR) + "/scenes/cloud.json";
    const SceneDesc desc =
        load_scene_desc(path, {"camera.width=32", "camera.height=18", "render.spp=4096"});
    const Report r = run_pipeline(desc, true).report;
    ASSERT_EQ(r.iterations.size(), 2u);
    EXPECT_EQ(r.spp, 4096);
    EXPECT_NE(r.plan_text.find("render.spp 4096 as 2 progressive iterations of 2048 spp"),
              std::string::npos)
        << r.plan_text;
    const float alpha = desc.progressive.alpha;  // r2^3 = r1^3 (1 + alpha) / 2
    EXPECT_NEAR(std::pow(r.iterations[1].radii.volume / r.iterations[0].radii.volume, 3.0f),
                (1.0f + alpha) / 2.0f, 1e-5f);
}

// Camera paths ending in the volume map gather about k photons where the ball holds many, k
// shrinking with the ball's volume over progressive iterations: k_i = k_1 (r_i / r_1)^3 =
// k_1 Π_{j<i} (j + α)/(j + 1) (Knaus and Zwicker's schedule), k_1 = twice volume.k's default for
// cloud.json's g 0.85 (render/run_setup.h, volume_k). Recorded per iteration in the report.
TEST(Progressive, TheAdaptiveRadiusGathersFewerPhotonsAsTheBallShrinks) {
    const std::string path = std::string(FOGMAP_SOURCE_DIR) + "/scenes/cloud.json";
    const std::vector<std::string> o{
        "camera.width=16",          "camera.height=9",          "render.spp=1",
        "advanced.iteration_spp=1", "progressive.iterations=8", "photons.volume=2000"};
    const Report r = run_pipeline(load_scene_desc(path, o), true).report;
    ASSERT_EQ(r.iterations.size(), 8u);
    const double alpha = 2.0 / 3.0;
    double product = 1.0;
    for (size_t i = 0; i < r.iterations.size(); ++i) {
        SCOPED_TRACE("iteration " + std::to_string(i + 1));
        if (i > 0) product *= (double(i) + alpha) / (double(i) + 1.0);
        EXPECT_NEAR(r.iterations[i].volume_k, 2.0 * kDefaultVolumeK * product,
                    1e-4 * 2.0 * kDefaultVolumeK);
    }
}

}  // namespace
}  // namespace fogmap
