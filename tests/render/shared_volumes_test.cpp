// Every real volume in ../shared/volumes loads and renders with the path tracer: finite pixels,
// rays that miss the medium see exactly the sky, and rays through it lose energy (albedo 0.5).

#include "render/path_tracer.h"
#include "scene/scene.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

namespace fogmap {
namespace {

class SharedVolume : public ::testing::TestWithParam<const char*> {};

TEST_P(SharedVolume, RendersFiniteAndAttenuatesTheSky) {
    const std::string path = std::string(FOGMAP_SHARED_VOLUMES) + "/" + GetParam();
    if (!std::filesystem::exists(path)) return test::missing_shared_volume(path);
    SceneDesc d;
    LightDesc sky;
    sky.type = LightType::Environment;
    sky.radiance = Color(1.0f);
    d.lights.push_back(sky);
    MediumDesc m;
    m.type = MediumType::Vdb;
    m.file = path;
    d.media.push_back(m);
    // Size the coefficients to the grid: optical depth ~20 across its extent at density 1.
    Box3 bounds = load_scene(d)->media[0].world_bounds();
    const float extent = max_component(bounds.extent());
    d.media[0].sigma_s = d.media[0].sigma_a = Color(10.0f / extent);
    d.camera.look_at = bounds.center();
    d.camera.position = bounds.center() + Vec3(0.0f, 0.0f, 2.0f * extent);
    d.camera.fov_deg = 40.0f;
    d.camera.width = 24;
    d.camera.height = 24;
    const auto scene = load_scene(d);
    RenderSettings rs;
    rs.spp = 4;
    const Image img = render_path(*scene, rs, true, nullptr).beauty;
    float darkest = 1.0f;
    for (const Color& c : img.pixels) {
        ASSERT_TRUE(is_finite(c));
        darkest = std::min(darkest, max_component(c));
    }
    // The corners look past the volume's bounding box (half-width ≤ extent/2 at distance
    // ≥ 1.5 extent subtends < 18.5°, the corner rays are ~27° off-axis): exactly the sky.
    EXPECT_EQ(img.at(0, 0), Color(1.0f));
    EXPECT_EQ(img.at(23, 23), Color(1.0f));
    // Somewhere the absorbing medium is dense enough to darken the sky clearly.
    EXPECT_LT(darkest, 0.8f);
}

INSTANTIATE_TEST_SUITE_P(AllFiles, SharedVolume,
                         ::testing::Values("smoke1.vdb", "wdas_cloud_sixteenth.vdb",
                                           "usd_smoke_000003.vdb", "usd_densityAndHeat.vdb"));

}  // namespace
}  // namespace fogmap
