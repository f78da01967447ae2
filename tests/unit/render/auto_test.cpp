// auto after the media are loaded (render/pipeline.h, refine_auto): the camera rays' median optical
// depth against its closed form through a homogeneous box, and thin media under the sun going to
// the path tracer, thick ones keeping the photon integrator.

#include "render/pipeline.h"
#include "scene/plan.h"
#include "scene/scene.h"
#include "scene_builders.h"

#include <gtest/gtest.h>

#include <string>

namespace fogmap {
namespace {

using namespace test;

// A sun over a 2 × 2 × 2 box of σ_t (per channel) seen head-on through a 2° field of view: every
// camera ray crosses it along the axis within 1 − cos 1.3° (0.03%), so the depth is 2 σ_t.
SceneDesc box_under_the_sun(const Color& sigma_s, const Color& sigma_a) {
    SceneDesc d;
    d.lights.push_back(sun(Vec3(0.3f, -1.0f, 0.2f), 2.0f));
    d.media.push_back(homogeneous(Box3{Vec3(-1.0f), Vec3(1.0f)}, sigma_s, sigma_a));
    d.camera.position = Vec3(0.0f, 0.0f, 5.0f);
    d.camera.look_at = Vec3(0.0f);
    d.camera.fov_deg = 2.0f;
    d.camera.width = 64;
    d.camera.height = 48;
    return choose_integrator(d);  // render.integrator auto
}

TEST(Auto, CameraOpticalDepthIsTheBoxsDepth) {
    const SceneDesc d = box_under_the_sun(Color(0.5f, 1.0f, 1.5f), Color(0.1f));
    const auto scene = load_scene(d);
    EXPECT_NEAR(camera_optical_depth(*scene, d.camera), 2.0f * 1.1f, 2.2f * 1e-3f);
    SceneDesc away = d;  // no ray meets the medium
    away.camera.look_at = Vec3(0.0f, 0.0f, 10.0f);
    EXPECT_EQ(camera_optical_depth(*scene, away.camera), 0.0f);
}

TEST(Auto, ThinMediaUnderTheSunGoToThePathTracer) {
    const SceneDesc thin = box_under_the_sun(Color(0.18f), Color(0.02f));  // depth 0.4
    ASSERT_TRUE(thin.render.auto_media);
    ASSERT_EQ(thin.render.integrator, Integrator::Photon);
    const SceneDesc path = refine_auto(thin, *load_scene(thin));
    EXPECT_EQ(path.render.integrator, Integrator::Path);
    EXPECT_NE(path.render.auto_reason.find("but thin: camera rays through the media have a "
                                           "median optical depth of 0.40 (below 0.5)"),
              std::string::npos)
        << path.render.auto_reason;

    const SceneDesc thick = box_under_the_sun(Color(0.27f), Color(0.03f));  // depth 0.6
    const SceneDesc photon = refine_auto(thick, *load_scene(thick));
    EXPECT_EQ(photon.render.integrator, Integrator::Photon);
    EXPECT_NE(photon.render.auto_reason.find("median optical depth of 0.60"), std::string::npos)
        << photon.render.auto_reason;

    SceneDesc progressive = thin;  // the path tracer has no progressive iterations
    progressive.progressive.iterations = 4;
    EXPECT_EQ(refine_auto(progressive, *load_scene(progressive)).render.integrator,
              Integrator::Photon);
    SceneDesc named = thin;  // a scene that names its integrator keeps it
    named.render.auto_media = false;
    EXPECT_EQ(refine_auto(named, *load_scene(named)).render.integrator, Integrator::Photon);
}

}  // namespace
}  // namespace fogmap
