#pragma once
// SceneDesc: the plain, validated content of a scene file. Every field has its default here, its
// JSON key equals the field name (snake_case), and units are stated per field. Parsing lives in
// scene_desc_json.h, range and cross-field checks in validate(). No third-party types here.

#include "core/math.h"
#include "media/march_settings.h"
#include "surface/material.h"

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace fogmap {

/// Affine transform written in a scene file as {"translate", "rotate_deg", "scale"} (applied
/// scale, then rotations about x, y, z in that order, then translation) or {"matrix": 16 numbers,
/// row-major}. Identity by default.
struct TransformDesc {
    Mat4 matrix{1.0f};
};

/// A camera's shutter for motion blur by the media's velocity grids: open and close in frames
/// around the frame (each in [-1, 1], open <= close), at fps frames per second (velocity grids are
/// in world units per second, as Houdini and Blender write them).
struct ShutterDesc {
    float open = -0.25f, close = 0.25f;  ///< frames; a 180° shutter centred on the frame
    float fps = 24.0f;
    /// The time, seconds from the frame, at fraction u in [0, 1] of the shutter's interval.
    float seconds(float u) const { return (open + u * (close - open)) / fps; }
};

struct CameraDesc {
    Vec3 position{0.0f, 1.0f, 5.0f};  ///< world units
    Vec3 look_at{0.0f, 1.0f, 0.0f};
    Vec3 up{0.0f, 1.0f, 0.0f};
    float fov_deg = 40.0f;  ///< vertical field of view, degrees, in (0, 180)
    int width = 640;        ///< pixels, >= 1
    int height = 360;       ///< pixels, >= 1
    /// absent: no motion blur (a medium's velocity grid is then not read)
    std::optional<ShutterDesc> shutter;
};

enum class LightType { Point, Spot, Quad, Sun, Environment };

struct LightDesc {
    LightType type = LightType::Point;
    Color intensity{1.0f};              ///< point, spot: radiant intensity, W/sr
    Vec3 position{0.0f};                ///< point, spot: world position
    Vec3 direction{0.0f, -1.0f, 0.0f};  ///< spot, sun: the direction light travels (normalised)
    float cone_angle_deg = 30.0f;       ///< spot: half-angle where intensity reaches 0
    float cone_delta_deg = 5.0f;        ///< spot: width of the smooth falloff inside the cone
    Vec3 corner{0.0f};                  ///< quad: one corner
    Vec3 edge_u{1.0f, 0.0f, 0.0f};      ///< quad: first edge; emits towards edge_u x edge_v
    Vec3 edge_v{0.0f, 0.0f, 1.0f};      ///< quad: second edge
    Color radiance{1.0f};               ///< quad, environment: W/(m^2 sr)
    Color irradiance{1.0f};             ///< sun: W/m^2 on a surface facing the sun
    float angular_radius_deg = 0.0f;    ///< sun: 0 = a delta direction; the real sun is ~0.27
};

struct MaterialDesc {
    MaterialType type = MaterialType::Diffuse;
    Color albedo{0.8f};  ///< diffuse: reflectance in [0, 1]; mirror: reflectance in [0, 1]
    float ior = 1.5f;    ///< glass: index of refraction (> 0), outside is 1
};

enum class ShapeType { Quad, Box, Sphere, Mesh };

struct ShapeDesc {
    ShapeType type = ShapeType::Quad;
    std::string material;           ///< key into SceneDesc::materials
    Vec3 corner{0.0f};              ///< quad
    Vec3 edge_u{1.0f, 0.0f, 0.0f};  ///< quad
    Vec3 edge_v{0.0f, 0.0f, 1.0f};  ///< quad
    Vec3 min{-0.5f}, max{0.5f};     ///< box (axis-aligned before the transform)
    Vec3 center{0.0f};              ///< sphere
    float radius = 1.0f;            ///< sphere, > 0
    std::string file;               ///< mesh: OBJ or PLY path, relative to the scene file
    TransformDesc transform;        ///< applied to the shape (sphere: translation+uniform scale)
};

enum class MediumType { Vdb, Homogeneous };

/// What "emission" of a medium draws L_e from (media/emission.h). auto: blackbody for a grid named
/// temperature, scalar for another grid, constant without a grid (a VDB medium first looks for a
/// grid named temperature, heat, flame or flames in its file, in that order).
enum class EmissionSource { Auto, Blackbody, Scalar, Constant };

struct EmissionDesc {
    EmissionSource kind = EmissionSource::Auto;
    std::string grid;                 ///< float grid of the medium's file; "" = look for one
    Color color{1.0f};                ///< scalar: radiance per grid unit; constant: L_e
    float scale = 1.0f;               ///< multiplies L_e (>= 0)
    float temperature_scale = 1.0f;   ///< blackbody: kelvin per grid unit (>= 0)
    float temperature_offset = 0.0f;  ///< blackbody: kelvin added
};

struct MediumDesc {
    MediumType type = MediumType::Vdb;
    std::string file;              ///< vdb: path relative to the scene file
    std::string grid = "density";  ///< vdb: name of a float grid
    std::string color_grid;        ///< vdb: a vec3s grid, the scattering's albedo per channel
    std::string velocity_grid;     ///< vdb: a vec3s grid, world units per second (motion blur)
    TransformDesc transform;       ///< vdb: scene transform applied after the grid's own
    float density_scale = 1.0f;    ///< multiplies the grid values (>= 0)
    Color sigma_s{1.0f};           ///< scattering coefficient per unit density, 1/world unit
    Color sigma_a{0.0f};           ///< absorption coefficient per unit density, 1/world unit
    float g = 0.0f;                ///< Henyey-Greenstein asymmetry in (-1, 1)
    std::optional<Box3>
        bounds;  ///< homogeneous: box ("bounds": {"min","max"}); absent = whole scene
    std::optional<EmissionDesc> emission;  ///< absent: the medium does not emit
};

/// path: the unbiased path tracer; photon: photon mapping; guided: the path tracer with camera
/// paths split in media where the volume photon map has light to come (and, by guide_vertices,
/// directions guided by it; unbiased); auto: the Plan picks one of them for the scene
/// (render/run_setup.h, choose_integrator).
enum class Integrator { Path, Photon, Guided, Auto };

/// The share of what a safety limit may cut before it is a warning: render.max_depth of the
/// camera samples, photons.max_bounces of the emitted photon power (docs/design.md, The path
/// tracer); `fogmap validate` fails above it. A cut biases the result low by about its share.
inline constexpr double kCapWarnShare = 0.001;

struct RenderSettings {
    Integrator integrator = Integrator::Auto;
    int spp = 16;  ///< samples per pixel, >= 1
    /// Photon integrator: about how many of a pixel's spp samples look up the photon maps (0 =
    /// all). A lookup costs many times the rest of a sample, so the others only trace the camera
    /// side (direct light, single scattering); the chosen ones weigh spp / map_spp rounded down
    /// (unbiased: map_weight in render/photon_integrator.h).
    int map_spp = 4;
    /// Guided integrator: medium vertices along a path (the first ones) whose scattering
    /// direction is sampled from the volume photons' incident directions mixed with the phase
    /// function (render/volume_guide.h); 0 = none, the map then drives splitting alone.
    int guide_vertices = 0;
    /// Scattering/bounce vertices per path, >= 1 (1 = direct light only). Paths end by Russian
    /// roulette; this is a safety limit far beyond what media of albedo < 1 reach, and what it
    /// cuts is reported (a warning above kCapWarnShare of the samples).
    int max_depth = 1000000;
    uint64_t seed = 1;  ///< results are a function of the seed alone
    int threads = 0;    ///< 0 = all cores
    /// Adaptive sampling: spp sets the work, a pixel's samples follow its neighbours' error
    /// (render/film.h, render_film), in a plain render or across a run's iterations (run_setup.h,
    /// adaptive_sampling and measured_iterations).
    bool adaptive = true;
};

/// The volume map's budget when the scene gives none and no rule sets it.
inline constexpr uint64_t kDefaultVolumePhotons = 100000;

/// Photon budgets (docs/design.md, Pipeline): photons *stored* per map; shooting goes on until
/// every map with a budget is full or max_emitted photons have left the lights. 0 = map not built.
struct PhotonDesc {
    uint64_t global = 100000;  ///< diffuse hits after at least one bounce
    uint64_t caustic = 50000;  ///< L S+ D paths
    /// Scattering events in media after at least one interaction; absent = by rule
    /// (render/run_setup.h, volume_budget), kDefaultVolumePhotons where no rule applies.
    std::optional<uint64_t> volume;
    uint64_t max_emitted = 0;  ///< cap on emitted photons; 0 = 100 x the largest budget
    /// Interactions per photon path, >= 1. Photons end by Russian roulette on the albedo; this is
    /// a safety limit, and the power it cuts is reported (a warning above kCapWarnShare).
    int max_bounces = 1000000;
    uint64_t volume_or_default() const { return volume.value_or(kDefaultVolumePhotons); }
};

/// Surface global map: disc estimate, shown directly or through final gathering.
struct GlobalGatherSettings {
    int k = 100;                ///< photons per estimate, >= 1
    float radius = 0.0f;        ///< max radius, world units; 0 = 2% of the scene diagonal
    bool final_gather = false;  ///< gather rays at camera hits instead of showing the map
    int gather_rays = 32;       ///< rays per final gather, >= 1
};

/// Surface caustic map: disc estimate with optional cone filter (Jensen, k_f >= 1; 0 = off).
struct CausticGatherSettings {
    int k = 50;
    float radius = 0.0f;       ///< max radius, world units; 0 = 1% of the scene diagonal
    float cone_filter = 0.0f;  ///< Jensen's k_f; 0 = box filter
};

inline constexpr int kDefaultVolumeK = 50;

/// sphere: point queries along the camera march; beam: one query per ray segment over photon
/// spheres (Jarosz, Zwicker, Jensen 2008); photon_beams: one query per ray segment over the photon
/// paths' segments blurred into cylinders (photon/photon_beams.h; Jarosz, Nowrouzezahrai, Sadeghi,
/// Jensen 2011).
enum class VolumeEstimator { Sphere, Beam, PhotonBeams };

/// Volume map: the beam estimate with per-photon radii (the k-th neighbour's distance, at most
/// `radius`), or the spherical estimate Σ p ΔΦ / ((4/3) π r³) (docs/design.md, Radiance
/// estimates). The beam is the default: the sphere blurs photons from inside a dense medium onto
/// the camera's side of its edge, where the transmittance is higher (docs/measurements.md).
struct VolumeGatherSettings {
    /// Photons per estimate; absent = by rule (render/run_setup.h, volume_k), kDefaultVolumeK
    /// where no rule applies.
    std::optional<int> k;
    float radius = 0.0f;  ///< max radius, world units; 0 = 5% of the media diagonal
    VolumeEstimator estimator = VolumeEstimator::Beam;
    /// Volume-map lookups per camera ray: at steps drawn by stratified importance sampling of
    /// the march's weights and reweighted, so the march sum stays unbiased; 0 = every step.
    int lookups_per_ray = 8;
    /// Single scattering along each marched camera segment: shadow rays per light at points
    /// drawn ∝ the march's weights (and, for point and spot lights, as many again by equi-angular
    /// sampling, combined by the balance heuristic); 0 = a shadow ray at every step.
    int light_samples = 4;
    /// Photon integrator: 0 = camera rays march and see the volume map directly; D >= 1 = camera
    /// paths are traced as the path tracer traces them through D scattering vertices (in media
    /// and on diffuse surfaces) and end in the volume map at a medium vertex, the D-th or later
    /// (render/volume_map_end.h), within the radius at which the median photon has k
    /// neighbours; surfaces are path traced (no surface maps).
    int gather_depth = 0;
    /// gather_depth >= 1: a path ends at the medium vertex that is its D-th scattering vertex
    /// (diffuse surface bounces count) or the first after it where the map's ball spans at most
    /// this many scattering mean free paths (σ̄_s r <= gather_tau), by vertex 4D at the latest; 0 =
    /// always at the D-th (render/volume_map_end.h, FineEnough).
    float gather_tau = 1.5f;
    /// gather_depth >= 1: the camera paths' shadow rays to a sun (up to 1° wide) read the media's
    /// optical depth along it from a grid with nodes this many voxels apart (render/sun_shadows.h;
    /// built once per render when every medium is a grid); 0 = ratio-tracked shadow rays.
    float sun_grid = 1.0f;
    int k_or_default() const { return k.value_or(kDefaultVolumeK); }
};


/// The most iterations a progressive run (or a plain render split into iterations) takes.
inline constexpr int kMaxProgressiveIterations = 1000000;

/// Iterations summed into one film, on when iterations, time_budget or target_relmse > 0:
/// progressive photon mapping (Knaus & Zwicker 2011) for the photon methods, each iteration a
/// photon pass and a render with shrinking fixed radii; render.spp fresh samples an iteration for
/// the path and guided tracers.
struct ProgressiveDesc {
    int iterations = 0;         ///< stop after this many iterations (0 = no limit)
    float time_budget = 0.0f;   ///< stop once this many seconds have passed (0 = no limit)
    /// Stop once the error estimate's 95% upper bound is at most this relMSE (0 = no target),
    /// looked at after kFirstLook, then twice as many, ... iterations (render/pipeline.cpp).
    float target_relmse = 0.0f;
    float alpha = 2.0f / 3.0f;  ///< radius reduction, in (0, 1)
    /// Camera samples per pixel in each iteration; 0 = by rule (render/run_setup.h,
    /// iteration_size).
    int spp = 0;
    bool enabled() const { return iterations > 0 || time_budget > 0.0f || target_relmse > 0.0f; }
};

struct SceneDesc {
    std::string path;      ///< the scene file (for messages); "" when built in code
    std::string base_dir;  ///< folder that relative file paths resolve against
    CameraDesc camera;
    std::vector<LightDesc> lights;
    std::map<std::string, MaterialDesc> materials;
    std::vector<ShapeDesc> shapes;
    std::vector<MediumDesc> media;
    RenderSettings render;
    PhotonDesc photons;
    GlobalGatherSettings global;
    CausticGatherSettings caustic;
    VolumeGatherSettings volume;
    MarchSettings march;
    ProgressiveDesc progressive;
};

/// String tables shared by the parser, its error messages and the report.
const char* to_string(LightType t);
const char* to_string(MaterialType t);
const char* to_string(ShapeType t);
const char* to_string(MediumType t);
const char* to_string(EmissionSource t);
const char* to_string(Integrator t);
const char* to_string(VolumeEstimator t);
const char* to_string(FreePathMethod t);

/// Range and cross-field checks (materials referenced by shapes exist, coefficients finite and
/// >= 0, g in (-1, 1), resolution >= 1, ...). Throws InputError{desc.path, json pointer, reason}.
void validate(const SceneDesc& desc);

}  // namespace fogmap
