#include "scene/scene_desc.h"

#include "core/error.h"
#include "core/world_range.h"
#include "media/blackbody.h"

#include <cmath>
#include <cstdio>
#include <limits>

namespace fogmap {

const char* to_string(LightType t) {
    switch (t) {
        case LightType::Point:
            return "point";
        case LightType::Spot:
            return "spot";
        case LightType::Quad:
            return "quad";
        case LightType::Sun:
            return "sun";
        case LightType::Environment:
            return "environment";
    }
    return "?";
}

const char* to_string(MaterialType t) {
    switch (t) {
        case MaterialType::Diffuse:
            return "diffuse";
        case MaterialType::Mirror:
            return "mirror";
        case MaterialType::Glass:
            return "glass";
    }
    return "?";
}

const char* to_string(ShapeType t) {
    switch (t) {
        case ShapeType::Quad:
            return "quad";
        case ShapeType::Box:
            return "box";
        case ShapeType::Sphere:
            return "sphere";
        case ShapeType::Mesh:
            return "mesh";
    }
    return "?";
}

const char* to_string(MediumType t) {
    switch (t) {
        case MediumType::Vdb:
            return "vdb";
        case MediumType::Homogeneous:
            return "homogeneous";
    }
    return "?";
}

const char* to_string(EmissionSource t) {
    switch (t) {
        case EmissionSource::Auto:
            return "auto";
        case EmissionSource::Blackbody:
            return "blackbody";
        case EmissionSource::Scalar:
            return "scalar";
        case EmissionSource::Constant:
            return "constant";
    }
    return "?";
}

const char* to_string(Integrator t) {
    switch (t) {
        case Integrator::Path:
            return "path";
        case Integrator::Photon:
            return "photon";
        case Integrator::Guided:
            return "guided";
        case Integrator::Auto:
            return "auto";
    }
    return "?";
}

const char* to_string(VolumeEstimator t) {
    switch (t) {
        case VolumeEstimator::Sphere:
            return "sphere";
        case VolumeEstimator::Beam:
            return "beam";
        case VolumeEstimator::PhotonBeams:
            return "photon_beams";
    }
    return "?";
}

const char* to_string(FreePathMethod t) {
    switch (t) {
        case FreePathMethod::March:
            return "march";
        case FreePathMethod::Delta:
            return "delta";
    }
    return "?";
}

namespace {

constexpr int kMaxResolution = 16384;
constexpr int kMaxDepthLimit = 100000000;
constexpr uint64_t kMaxPhotonBudget = 1000000000;  // 1e9 records x ~20 bytes = 20 GB per map
constexpr int kMaxGatherK = 100000;
constexpr int kMaxGatherRays = 4096;
constexpr float kMaxStepVoxels = 1e6f;

std::string num(double x) {
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%g", x);
    return buf;
}

std::string vec(const Vec3& v) { return "[" + num(v.x) + ", " + num(v.y) + ", " + num(v.z) + "]"; }

bool finite(const Vec3& v) { return is_finite(v); }

// Checks collect the scene's path and one object's JSON pointer; each failed check throws
// InputError{path, pointer/key, "<key> ...; found ..."}.
class Checker {
public:
    Checker(const SceneDesc& desc, std::string pointer)
        : file_(desc.path), pointer_(std::move(pointer)) {}

    [[noreturn]] void fail(const std::string& key, const std::string& reason) const {
        throw InputError(file_, key.empty() ? pointer_ : pointer_ + "/" + key, reason);
    }
    void finite_vec(const std::string& key, const Vec3& v) const {
        if (!finite(v)) fail(key, key + " must be finite; found " + vec(v));
    }
    void non_negative(const std::string& key, const Color& c) const {
        finite_vec(key, c);
        if (c.x < 0.0f || c.y < 0.0f || c.z < 0.0f) {
            fail(key, key + " must be >= 0 per channel; found " + vec(c));
        }
    }
    void non_negative(const std::string& key, float x) const {
        if (!std::isfinite(x) || x < 0.0f)
            fail(key, key + " must be finite and >= 0; found " + num(x));
    }
    void unit_interval(const std::string& key, const Color& c) const {
        non_negative(key, c);
        if (c.x > 1.0f || c.y > 1.0f || c.z > 1.0f) {
            fail(key, key + " must be in [0, 1] per channel; found " + vec(c));
        }
    }
    void non_zero(const std::string& key, const Vec3& v) const {
        finite_vec(key, v);
        if (glm::length(v) == 0.0f) fail(key, key + " must be a non-zero vector; found " + vec(v));
    }
    void int_range(const std::string& key, int x, int lo, int hi) const {
        if (x < lo || x > hi) {
            fail(key, key + " must be in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                          "]; found " + std::to_string(x));
        }
    }
    void uint_range(const std::string& key, uint64_t x, uint64_t lo, uint64_t hi) const {
        if (x < lo || x > hi) {
            fail(key, key + " must be in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                          "]; found " + std::to_string(x));
        }
    }
    /// Open interval (lo, hi) when open, else half-open [lo, hi).
    void range(const std::string& key, float x, float lo, float hi, bool open_lo) const {
        const bool ok = std::isfinite(x) && (open_lo ? x > lo : x >= lo) && x < hi;
        if (!ok) {
            fail(key, key + " must be in " + (open_lo ? "(" : "[") + num(lo) + ", " + num(hi) +
                          "); found " + num(x));
        }
    }
    void box(const std::string& key, const Vec3& lo, const Vec3& hi, const char* lo_name,
             const char* hi_name) const {
        finite_vec(key, lo);
        finite_vec(key, hi);
        if (!(lo.x < hi.x && lo.y < hi.y && lo.z < hi.z)) {
            fail(key, std::string(lo_name) + " must be < " + hi_name + " on every axis; found " +
                          lo_name + " " + vec(lo) + ", " + hi_name + " " + vec(hi));
        }
    }
    /// Every coordinate of v within ±kMaxWorldCoordinate (core/world_range.h).
    void world_point(const std::string& key, const Vec3& v) const {
        finite_vec(key, v);
        for (int a = 0; a < 3; ++a)
            if (!(std::abs(double(v[a])) <= kMaxWorldCoordinate))
                fail(key, key + " must lie within ±" + num(kMaxWorldCoordinate) +
                              " world units on every axis; found " + vec(v));
    }
    /// A transform that places things in the world: finite, invertible, scales in range.
    void transform(const Mat4& m) const {
        const std::string problem = affine_problem(m);
        if (!problem.empty()) fail("transform", "transform " + problem);
    }
    /// The world box of a shape, `what` in the message ("the transformed shape").
    void world_box(const std::string& key, const Box3& b, const char* what) const {
        if (!within_world(b))
            fail(key, std::string(what) + " spans " + box_text(b) +
                          "; expected every coordinate within ±" + num(kMaxWorldCoordinate) +
                          " world units");
    }
    /// factor * c per channel, computed in double, at most kMaxLightPower; `what` names the
    /// product and `unit` its unit in the message ("a power", "W").
    void power(const std::string& key, const Color& c, double factor, const char* what,
               const char* unit) const {
        for (int i = 0; i < 3; ++i) {
            const double p = factor * double(c[i]);
            if (!(p <= kMaxLightPower))
                fail(key, key + " " + vec(c) + " gives " + what + " of " + num(p) + " " + unit +
                              " (channel " + std::to_string(i) + "); expected at most " +
                              num(kMaxLightPower) + " " + unit + " per channel");
        }
    }
    void parallelogram(const Vec3& u, const Vec3& v) const {
        finite_vec("edge_u", u);
        finite_vec("edge_v", v);
        if (glm::length(glm::cross(u, v)) == 0.0f) {
            fail("edge_v", "edge_u " + vec(u) + " and edge_v " + vec(v) +
                               " span no area; expected two non-parallel, non-zero edges");
        }
    }

private:
    std::string file_;
    std::string pointer_;
};

Box3 parallelogram_box(const Vec3& corner, const Vec3& u, const Vec3& v) {
    Box3 b;
    for (const Vec3& p : {corner, corner + u, corner + v, corner + u + v}) b.extend(p);
    return b;
}

void check_camera(const SceneDesc& desc) {
    const CameraDesc& c = desc.camera;
    const Checker k(desc, "/camera");
    k.int_range("width", c.width, 1, kMaxResolution);
    k.int_range("height", c.height, 1, kMaxResolution);
    k.range("fov_deg", c.fov_deg, 0.0f, 180.0f, true);
    if (c.shutter) {
        const Checker s(desc, "/camera/shutter");
        for (const auto& [key, frames] :
             {std::pair{"open", c.shutter->open}, std::pair{"close", c.shutter->close}})
            if (!(frames >= -1.0f && frames <= 1.0f))
                s.fail(key, std::string(key) +
                                " must be in [-1, 1] frames around the frame; found " +
                                num(frames));
        if (c.shutter->open > c.shutter->close)
            s.fail("close", "close " + num(c.shutter->close) + " is before open " +
                                num(c.shutter->open) + "; expected open <= close");
        if (!(c.shutter->fps > 0.0f && c.shutter->fps <= 1e6f))
            s.fail("fps",
                   "fps must be in (0, 1e6] frames per second; found " + num(c.shutter->fps));
    }
    k.world_point("position", c.position);
    k.world_point("look_at", c.look_at);
    k.non_zero("up", c.up);
    const Vec3 view = c.look_at - c.position;
    if (glm::length(view) == 0.0f) {
        k.fail("look_at", "look_at equals position " + vec(c.position) +
                              "; expected a point away from the camera");
    }
    // Relative test: sin of the angle between up and view below ~1e-6 is parallel for a float.
    if (glm::length(glm::cross(glm::normalize(view), glm::normalize(c.up))) < 1e-6f) {
        k.fail("up", "up " + vec(c.up) + " is parallel to the view direction " + vec(view) +
                         "; expected a vector not parallel to look_at - position");
    }
}

void check_light(const SceneDesc& desc, size_t i) {
    const LightDesc& l = desc.lights[i];
    const Checker k(desc, "/lights/" + std::to_string(i));
    switch (l.type) {
        case LightType::Point:
            k.non_negative("intensity", l.intensity);
            k.power("intensity", l.intensity, 4.0 * kPi, "a power", "W");
            k.world_point("position", l.position);
            break;
        case LightType::Spot:
            k.non_negative("intensity", l.intensity);
            k.power("intensity", l.intensity, 4.0 * kPi, "a power up to", "W");
            k.world_point("position", l.position);
            k.non_zero("direction", l.direction);
            k.range("cone_angle_deg", l.cone_angle_deg, 0.0f, 180.0f, true);
            if (!std::isfinite(l.cone_delta_deg) || l.cone_delta_deg < 0.0f ||
                l.cone_delta_deg > l.cone_angle_deg) {
                k.fail("cone_delta_deg",
                       "cone_delta_deg must be in [0, cone_angle_deg = " + num(l.cone_angle_deg) +
                           "]; found " + num(l.cone_delta_deg));
            }
            break;
        case LightType::Quad:
            k.world_point("corner", l.corner);
            k.parallelogram(l.edge_u, l.edge_v);
            k.world_box("edge_v", parallelogram_box(l.corner, l.edge_u, l.edge_v), "the quad");
            k.non_negative("radiance", l.radiance);
            k.power("radiance", l.radiance,
                    kPi * glm::length(glm::dvec3(glm::cross(l.edge_u, l.edge_v))), "a power", "W");
            break;
        case LightType::Sun:
            // The power (irradiance times the scene's cross-section) is checked at load, when
            // the scene's bounds are known (scene.cpp); here the irradiance itself.
            k.non_zero("direction", l.direction);
            k.non_negative("irradiance", l.irradiance);
            k.power("irradiance", l.irradiance, 1.0, "an irradiance", "W/m^2");
            k.range("angular_radius_deg", l.angular_radius_deg, 0.0f, 45.0f, false);
            break;
        case LightType::Environment:
            k.non_negative("radiance", l.radiance);
            k.power("radiance", l.radiance, 4.0 * kPi * kPi, "a power per unit of cross-section",
                    "W/m^2");
            break;
    }
}

void check_material(const SceneDesc& desc, const std::string& name, const MaterialDesc& m) {
    std::string pointer = "/materials/";
    for (char c : name) pointer += c == '~' ? "~0" : c == '/' ? "~1" : std::string(1, c);
    const Checker k(desc, pointer);
    switch (m.type) {
        case MaterialType::Diffuse:
        case MaterialType::Mirror:
            k.unit_interval("albedo", m.albedo);
            break;
        case MaterialType::Glass:
            if (!std::isfinite(m.ior) || m.ior <= 0.0f) {
                k.fail("ior", "ior must be finite and > 0; found " + num(m.ior));
            }
            break;
    }
}

// A sphere stays a sphere only under rotation, uniform scale and translation: the columns of
// the linear part must be orthogonal and of equal, non-zero length (relative tolerance 1e-4).
void check_similarity(const Checker& k, const Mat4& m) {
    const Vec3 c[3] = {Vec3(m[0]), Vec3(m[1]), Vec3(m[2])};
    const Vec3 len(glm::length(c[0]), glm::length(c[1]), glm::length(c[2]));
    const float scale = max_component(len);
    const float tol = 1e-4f * scale * scale;
    const bool ok = scale > 0.0f && std::abs(len.x - len.y) <= 1e-4f * scale &&
                    std::abs(len.x - len.z) <= 1e-4f * scale &&
                    std::abs(glm::dot(c[0], c[1])) <= tol &&
                    std::abs(glm::dot(c[0], c[2])) <= tol && std::abs(glm::dot(c[1], c[2])) <= tol;
    if (!ok) {
        k.fail("transform",
               "a sphere's transform must be rotation, uniform scale and translation; "
               "found axis scales " +
                   vec(len) + " (or sheared axes)");
    }
}

void check_shape(const SceneDesc& desc, size_t i) {
    const ShapeDesc& s = desc.shapes[i];
    const Checker k(desc, "/shapes/" + std::to_string(i));
    if (!desc.materials.count(s.material)) {
        std::string known;
        for (const auto& item : desc.materials) known += (known.empty() ? "" : ", ") + item.first;
        k.fail("material", "unknown material '" + s.material + "'; " +
                               (known.empty() ? std::string("the scene defines no materials")
                                              : "known materials: " + known));
    }
    const Mat4& m = s.transform.matrix;
    for (int c = 0; c < 4; ++c) {
        if (!finite(Vec3(m[c]))) k.fail("transform", "transform is not finite");
    }
    k.transform(m);
    Box3 world;  // corners of the shape (its bounding box for a sphere) after the transform
    const auto add = [&](const Vec3& p) { world.extend(transform_point(m, p)); };
    switch (s.type) {
        case ShapeType::Quad:
            k.world_point("corner", s.corner);
            k.parallelogram(s.edge_u, s.edge_v);
            k.world_box("edge_v", parallelogram_box(s.corner, s.edge_u, s.edge_v), "the quad");
            for (const Vec3& p : {s.corner, s.corner + s.edge_u, s.corner + s.edge_v,
                                  s.corner + s.edge_u + s.edge_v})
                add(p);
            break;
        case ShapeType::Box:
            k.world_point("min", s.min);
            k.world_point("max", s.max);
            k.box("max", s.min, s.max, "min", "max");
            for (int c = 0; c < 8; ++c)
                add(Vec3(c & 1 ? s.max.x : s.min.x, c & 2 ? s.max.y : s.min.y,
                         c & 4 ? s.max.z : s.min.z));
            break;
        case ShapeType::Sphere:
            k.world_point("center", s.center);
            check_similarity(k, m);
            if (!std::isfinite(s.radius) || s.radius <= 0.0f) {
                k.fail("radius", "radius must be finite and > 0; found " + num(s.radius));
            }
            for (int c = 0; c < 8; ++c)
                add(s.center + s.radius * Vec3(c & 1 ? 1.0f : -1.0f, c & 2 ? 1.0f : -1.0f,
                                               c & 4 ? 1.0f : -1.0f));
            break;
        case ShapeType::Mesh:  // its vertices are checked when the file is read (scene.cpp)
            if (s.file.empty()) k.fail("file", "file is empty; expected an .obj or .ply path");
            break;
    }
    if (!world.empty()) k.world_box("transform", world, "the transformed shape");
}

/// The emission's own ranges, and what it needs of its medium; the hottest temperature is checked
/// at load (scene.cpp), where the grid's values are known.
void check_emission(const SceneDesc& desc, size_t i) {
    const MediumDesc& m = desc.media[i];
    const EmissionDesc& e = *m.emission;
    const Checker k(desc, "/media/" + std::to_string(i) + "/emission");
    k.non_negative("color", e.color);
    k.non_negative("scale", e.scale);
    k.non_negative("temperature_scale", e.temperature_scale);
    if (!std::isfinite(e.temperature_offset) || std::abs(e.temperature_offset) > kMaxKelvin)
        k.fail("temperature_offset", "temperature_offset must be finite, within ±" +
                                         num(kMaxKelvin) + " K; found " +
                                         num(e.temperature_offset));
    const bool grid_kind = e.kind == EmissionSource::Blackbody || e.kind == EmissionSource::Scalar;
    if (m.type == MediumType::Homogeneous && (grid_kind || !e.grid.empty()))
        k.fail(e.grid.empty() ? "kind" : "grid",
               "a homogeneous medium has no grids to emit from; expected kind \"constant\" (or "
               "\"auto\") and no grid");
    if (e.kind == EmissionSource::Constant && !e.grid.empty())
        k.fail("grid", "kind \"constant\" takes no grid; found grid \"" + e.grid + "\"");
    if (max_component(m.sigma_a) <= 0.0f)
        k.fail("",
               "the medium emits σ_a·L_e and its sigma_a is 0, so it would emit nothing; give "
               "sigma_a > 0 (the emission's strength is sigma_a × density × L_e)");
}

void check_medium(const SceneDesc& desc, size_t i) {
    const MediumDesc& m = desc.media[i];
    const Checker k(desc, "/media/" + std::to_string(i));
    k.non_negative("sigma_s", m.sigma_s);
    k.non_negative("sigma_a", m.sigma_a);
    k.non_negative("density_scale", m.density_scale);
    // The media use (sigma_s + sigma_a) * density_scale per unit density (scene.cpp): each finite
    // factor can still overflow float in the product, and an infinite sigma_t makes delta
    // tracking divide Inf by Inf (NaN) or walk forever. Checked in double, per channel.
    for (int c = 0; c < 3; ++c) {
        const double sigma_t = (double(m.sigma_s[c]) + m.sigma_a[c]) * m.density_scale;
        if (sigma_t > double(std::numeric_limits<float>::max())) {
            k.fail("density_scale", "(sigma_s + sigma_a) * density_scale must stay below " +
                                        num(std::numeric_limits<float>::max()) + "; found " +
                                        num(sigma_t) + " (channel " + std::to_string(c) + ")");
        }
    }
    if (!std::isfinite(m.g) || m.g <= -1.0f || m.g >= 1.0f) {
        k.fail("g", "g must be in (-1, 1); found " + num(m.g));
    }
    if (m.emission) check_emission(desc, i);
    switch (m.type) {
        case MediumType::Vdb:
            if (m.file.empty()) k.fail("file", "file is empty; expected a .vdb path");
            if (m.grid.empty()) k.fail("grid", "grid is empty; expected a float grid name");
            // The grid's own transform and the world bounds it gives are checked at load.
            k.transform(m.transform.matrix);
            break;
        case MediumType::Homogeneous:
            if (m.bounds) {
                k.box("bounds", m.bounds->lo, m.bounds->hi, "bounds.min", "bounds.max");
                k.world_point("bounds", m.bounds->lo);
                k.world_point("bounds", m.bounds->hi);
            }
            break;
    }
}

void check_render(const SceneDesc& desc) {
    const RenderSettings& r = desc.render;
    const Checker k(desc, "/render");
    if (r.spp < 1) k.fail("spp", "spp must be >= 1; found " + std::to_string(r.spp));
    k.int_range("max_depth", r.max_depth, 1, kMaxDepthLimit);
    if (r.threads < 0) {
        k.fail("threads",
               "threads must be >= 0 (0 = all cores); found " + std::to_string(r.threads));
    }
}

void check_photons(const SceneDesc& desc) {
    const PhotonDesc& p = desc.photons;
    const Checker k(desc, "/photons");
    // Negative budgets never get here: the reader rejects them as "expected a non-negative
    // integer". max_emitted has no upper bound: it is a cap, and 0 means automatic.
    k.uint_range("global", p.global, 0, kMaxPhotonBudget);
    k.uint_range("caustic", p.caustic, 0, kMaxPhotonBudget);
    k.uint_range("volume", p.volume_or_default(), 0, kMaxPhotonBudget);
    k.int_range("max_bounces", p.max_bounces, 1, kMaxDepthLimit);
}

void check_gather(const SceneDesc& desc) {
    {
        const GlobalGatherSettings& g = desc.global;
        const Checker k(desc, "/global");
        k.int_range("k", g.k, 1, kMaxGatherK);
        k.non_negative("radius", g.radius);
        k.int_range("gather_rays", g.gather_rays, 1, kMaxGatherRays);
    }
    {
        const CausticGatherSettings& c = desc.caustic;
        const Checker k(desc, "/caustic");
        k.int_range("k", c.k, 1, kMaxGatherK);
        k.non_negative("radius", c.radius);
        // Jensen's cone filter weight 1 - d/(k_f r) needs k_f >= 1 to stay non-negative.
        if (!std::isfinite(c.cone_filter) || (c.cone_filter != 0.0f && c.cone_filter < 1.0f)) {
            k.fail("cone_filter",
                   "cone_filter must be 0 (box filter) or finite and >= 1 "
                   "(Jensen's k_f); found " +
                       num(c.cone_filter));
        }
    }
    {
        const VolumeGatherSettings& v = desc.volume;
        const Checker k(desc, "/volume");
        k.int_range("k", v.k_or_default(), 1, kMaxGatherK);
        k.non_negative("radius", v.radius);
        k.int_range("gather_depth", v.gather_depth, 0, 1000);
        if (v.gather_depth > 0 && v.estimator == VolumeEstimator::PhotonBeams)
            k.fail("estimator",
                   "\"photon_beams\" gathers along camera rays, which gather_depth " +
                       std::to_string(v.gather_depth) +
                       " replaces by paths ending in the volume map; expected gather_depth 0 or "
                       "estimator \"sphere\" or \"beam\"");
        // A short beam's flux is its photon's power only where the free path was sampled with
        // every channel's own transmittance (photon/photon_beams.h).
        for (size_t i = 0; i < desc.media.size() && v.estimator == VolumeEstimator::PhotonBeams;
             ++i) {
            const Color t = desc.media[i].sigma_s + desc.media[i].sigma_a;
            if (t.x != t.y || t.y != t.z)
                k.fail("estimator",
                       "\"photon_beams\" needs the same extinction sigma_s + "
                       "sigma_a in every channel; /media/" +
                           std::to_string(i) + " has " + vec(t) +
                           "; expected \"beam\" or a grey medium");
        }
    }
}

void check_march(const SceneDesc& desc) {
    const MarchSettings& m = desc.march;
    const Checker k(desc, "/march");
    if (!std::isfinite(m.step_voxels) || m.step_voxels <= 0.0f || m.step_voxels > kMaxStepVoxels) {
        k.fail("step_voxels",
               "step_voxels must be finite, > 0 and <= 1000000; found " + num(m.step_voxels));
    }
    k.non_negative("step_world", m.step_world);
}

/// The research knobs of "advanced" (scene/scene_desc_json.cpp).
void check_advanced(const SceneDesc& desc) {
    const Checker k(desc, "/advanced");
    if (desc.render.map_spp < 0)
        k.fail("map_spp", "map_spp must be >= 0 (0 = every sample); found " +
                              std::to_string(desc.render.map_spp));
    k.int_range("guide_vertices", desc.render.guide_vertices, 0, kMaxDepthLimit);
    k.int_range("lookups_per_ray", desc.volume.lookups_per_ray, 0, 4096);
    k.int_range("light_samples", desc.volume.light_samples, 0, 4096);
    k.non_negative("gather_tau", desc.volume.gather_tau);
    k.non_negative("sun_grid", desc.volume.sun_grid);
    if (desc.progressive.spp < 0)
        k.fail("iteration_spp", "iteration_spp must be >= 0 (0 = by rule); found " +
                                    std::to_string(desc.progressive.spp));
}

void check_progressive(const SceneDesc& desc) {
    const ProgressiveDesc& p = desc.progressive;
    const Checker k(desc, "/progressive");
    k.int_range("iterations", p.iterations, 0, kMaxProgressiveIterations);
    k.non_negative("time_budget", p.time_budget);
    k.non_negative("target_relmse", p.target_relmse);
    k.range("alpha", p.alpha, 0.0f, 1.0f, true);
}

}  // namespace

void validate(const SceneDesc& desc) {
    check_camera(desc);
    for (size_t i = 0; i < desc.lights.size(); ++i) check_light(desc, i);
    for (const auto& [name, m] : desc.materials) check_material(desc, name, m);
    for (size_t i = 0; i < desc.shapes.size(); ++i) check_shape(desc, i);
    for (size_t i = 0; i < desc.media.size(); ++i) check_medium(desc, i);
    check_render(desc);
    check_photons(desc);
    check_gather(desc);
    check_march(desc);
    check_progressive(desc);
    check_advanced(desc);
}

}  // namespace fogmap
