#pragma once
// SceneDesc: the plain, validated content of a scene file. Every field has its default here, its
// JSON key equals the field name (snake_case), and units are stated per field. Parsing lives in
// scene_desc_json.h, range and cross-field checks in validate(). No third-party types here.

#include "core/math.h"

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

struct CameraDesc {
    Vec3 position{0.0f, 1.0f, 5.0f};  ///< world units
    Vec3 look_at{0.0f, 1.0f, 0.0f};
    Vec3 up{0.0f, 1.0f, 0.0f};
    float fov_deg = 40.0f;  ///< vertical field of view, degrees, in (0, 180)
    int width = 640;        ///< pixels, >= 1
    int height = 360;       ///< pixels, >= 1
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

enum class MaterialType { Diffuse, Mirror, Glass };

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

struct MediumDesc {
    MediumType type = MediumType::Vdb;
    std::string file;              ///< vdb: path relative to the scene file
    std::string grid = "density";  ///< vdb: name of a float grid
    TransformDesc transform;       ///< vdb: scene transform applied after the grid's own
    float density_scale = 1.0f;    ///< multiplies the grid values (>= 0)
    Color sigma_s{1.0f};           ///< scattering coefficient per unit density, 1/world unit
    Color sigma_a{0.0f};           ///< absorption coefficient per unit density, 1/world unit
    float g = 0.0f;                ///< Henyey-Greenstein asymmetry in (-1, 1)
    std::optional<Box3>
        bounds;  ///< homogeneous: box ("bounds": {"min","max"}); absent = whole scene
};

enum class Integrator { Path };

struct RenderSettings {
    Integrator integrator = Integrator::Path;
    int spp = 16;        ///< samples per pixel, >= 1
    int max_depth = 64;  ///< scattering/bounce vertices per path, >= 1 (1 = direct light only)
    uint64_t seed = 1;   ///< results are a function of the seed alone
    int threads = 0;     ///< 0 = all cores
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
};

/// String tables shared by the parser, its error messages and the report.
const char* to_string(LightType t);
const char* to_string(MaterialType t);
const char* to_string(ShapeType t);
const char* to_string(MediumType t);
const char* to_string(Integrator t);

/// Range and cross-field checks (materials referenced by shapes exist, coefficients finite and
/// >= 0, g in (-1, 1), resolution >= 1, ...). Throws InputError{desc.path, json pointer, reason}.
void validate(const SceneDesc& desc);

}  // namespace fogmap
