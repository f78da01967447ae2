#include "scene/scene_desc_json.h"

#include "core/error.h"
#include "core/hash.h"
#include "core/input_file.h"
#include "scene/json_reader.h"
#include "scene/vdb_scene.h"

#include <glm/gtc/matrix_transform.hpp>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>

namespace fogmap {

namespace {

using nlohmann::json;

constexpr std::array<LightType, 5> kLightTypes{LightType::Point, LightType::Spot, LightType::Quad,
                                               LightType::Sun, LightType::Environment};
constexpr std::array<MaterialType, 3> kMaterialTypes{MaterialType::Diffuse, MaterialType::Mirror,
                                                     MaterialType::Glass};
constexpr std::array<ShapeType, 4> kShapeTypes{ShapeType::Quad, ShapeType::Box, ShapeType::Sphere,
                                               ShapeType::Mesh};
constexpr std::array<MediumType, 2> kMediumTypes{MediumType::Vdb, MediumType::Homogeneous};
constexpr std::array<EmissionSource, 4> kEmissionSources{
    EmissionSource::Auto, EmissionSource::Blackbody, EmissionSource::Scalar,
    EmissionSource::Constant};
constexpr std::array<Integrator, 4> kIntegrators{Integrator::Auto, Integrator::Path,
                                                 Integrator::Photon, Integrator::Guided};
constexpr std::array<VolumeEstimator, 3> kVolumeEstimators{
    VolumeEstimator::Sphere, VolumeEstimator::Beam, VolumeEstimator::PhotonBeams};
constexpr std::array<FreePathMethod, 2> kFreePathMethods{FreePathMethod::March,
                                                         FreePathMethod::Delta};

// ---- Field lists -------------------------------------------------------------------------------
// One list per struct (and per type), walked by both the reader and the writer, so the keys a
// type accepts and the keys to_json writes cannot drift apart. The `type` key is handled by the
// callers because it selects the list; other enums go through `choice` with their string table.

template <class S, class V>
void shutter_fields(S& s, V& v) {
    v.value("open", s.open);
    v.value("close", s.close);
    v.value("fps", s.fps);
}

template <class C, class V>
void camera_fields(C& c, V& v) {
    v.vec3("position", c.position);
    v.vec3("look_at", c.look_at);
    v.vec3("up", c.up);
    v.value("fov_deg", c.fov_deg);
    v.value("width", c.width);
    v.value("height", c.height);
    v.object("shutter", c.shutter, [](auto& s, auto& f) { shutter_fields(s, f); });
}

template <class L, class V>
void light_fields(L& l, V& v) {
    switch (l.type) {
        case LightType::Point:
            v.color("intensity", l.intensity);
            v.vec3("position", l.position);
            break;
        case LightType::Spot:
            v.color("intensity", l.intensity);
            v.vec3("position", l.position);
            v.vec3("direction", l.direction);
            v.value("cone_angle_deg", l.cone_angle_deg);
            v.value("cone_delta_deg", l.cone_delta_deg);
            break;
        case LightType::Quad:
            v.vec3("corner", l.corner);
            v.vec3("edge_u", l.edge_u);
            v.vec3("edge_v", l.edge_v);
            v.color("radiance", l.radiance);
            break;
        case LightType::Sun:
            v.vec3("direction", l.direction);
            v.color("irradiance", l.irradiance);
            v.value("angular_radius_deg", l.angular_radius_deg);
            break;
        case LightType::Environment:
            v.color("radiance", l.radiance);
            break;
    }
}

template <class M, class V>
void material_fields(M& m, V& v) {
    switch (m.type) {
        case MaterialType::Diffuse:
        case MaterialType::Mirror:
            v.color("albedo", m.albedo);
            break;
        case MaterialType::Glass:
            v.value("ior", m.ior);
            break;
    }
}

template <class S, class V>
void shape_fields(S& s, V& v) {
    v.value("material", s.material);
    switch (s.type) {
        case ShapeType::Quad:
            v.vec3("corner", s.corner);
            v.vec3("edge_u", s.edge_u);
            v.vec3("edge_v", s.edge_v);
            break;
        case ShapeType::Box:
            v.vec3("min", s.min);
            v.vec3("max", s.max);
            break;
        case ShapeType::Sphere:
            v.vec3("center", s.center);
            v.value("radius", s.radius);
            break;
        case ShapeType::Mesh:
            v.value("file", s.file);
            break;
    }
    v.transform("transform", s.transform);
}

template <class E, class V>
void emission_fields(E& e, V& v) {
    v.choice("kind", e.kind, kEmissionSources, "emission kind");
    v.value("grid", e.grid);
    v.color("color", e.color);
    v.value("scale", e.scale);
    v.value("temperature_scale", e.temperature_scale);
    v.value("temperature_offset", e.temperature_offset);
}

template <class M, class V>
void medium_fields(M& m, V& v) {
    switch (m.type) {
        case MediumType::Vdb:
            v.value("file", m.file);
            v.value("grid", m.grid);
            v.value("color_grid", m.color_grid);
            v.value("velocity_grid", m.velocity_grid);
            v.transform("transform", m.transform);
            break;
        case MediumType::Homogeneous:
            v.bounds("bounds", m.bounds);
            break;
    }
    v.value("density_scale", m.density_scale);
    v.color("sigma_s", m.sigma_s);
    v.color("sigma_a", m.sigma_a);
    v.value("g", m.g);
    v.object("emission", m.emission, [](auto& e, auto& f) { emission_fields(e, f); });
}

template <class R, class V>
void render_fields(R& r, V& v) {
    v.choice("integrator", r.integrator, kIntegrators, "integrator");
    v.value("spp", r.spp);
    v.value("max_depth", r.max_depth);
    v.value("seed", r.seed);
    v.value("threads", r.threads);
    v.value("adaptive", r.adaptive);
}

template <class P, class V>
void photon_fields(P& p, V& v) {
    v.value("global", p.global);
    v.value("caustic", p.caustic);
    v.value("volume", p.volume);
    v.value("max_emitted", p.max_emitted);
    v.value("max_bounces", p.max_bounces);
}

template <class G, class V>
void global_fields(G& g, V& v) {
    v.value("k", g.k);
    v.value("radius", g.radius);
    v.value("final_gather", g.final_gather);
    v.value("gather_rays", g.gather_rays);
}

template <class C, class V>
void caustic_fields(C& c, V& v) {
    v.value("k", c.k);
    v.value("radius", c.radius);
    v.value("cone_filter", c.cone_filter);
}

template <class G, class V>
void volume_fields(G& g, V& v) {
    v.value("k", g.k);
    v.value("radius", g.radius);
    v.choice("estimator", g.estimator, kVolumeEstimators, "volume estimator");
    v.value("gather_depth", g.gather_depth);
}

/// The research knobs, all in one "advanced" object: each tunes one estimator's cost against its
/// noise, measured in docs/measurements.md; their defaults are what those measurements chose.
template <class D, class V>
void advanced_fields(D& d, V& v) {
    v.value("map_spp", d.render.map_spp);
    v.value("guide_vertices", d.render.guide_vertices);
    v.value("lookups_per_ray", d.volume.lookups_per_ray);
    v.value("light_samples", d.volume.light_samples);
    v.value("gather_tau", d.volume.gather_tau);
    v.value("sun_grid", d.volume.sun_grid);
    v.value("iteration_spp", d.progressive.spp);
}

/// Where each advanced key stood before it moved: a scene that still gives one there is told.
constexpr std::array<std::array<const char*, 3>, 7> kMovedKeys{{
    {"render", "map_spp", "map_spp"},
    {"render", "guide_vertices", "guide_vertices"},
    {"volume", "lookups_per_ray", "lookups_per_ray"},
    {"volume", "light_samples", "light_samples"},
    {"volume", "gather_tau", "gather_tau"},
    {"volume", "sun_grid", "sun_grid"},
    {"progressive", "spp", "iteration_spp"},
}};

void check_moved_keys(const json& doc, const std::string& file) {
    for (const auto& [section, key, now] : kMovedKeys) {
        const auto it = doc.find(section);
        if (it != doc.end() && it->is_object() && it->contains(key))
            throw InputError(file, std::string("/") + section + "/" + key,
                             std::string("moved to \"advanced\": {\"") + now +
                                 "\": ...} (the research knobs are together there)");
    }
}

template <class M, class V>
void march_fields(M& m, V& v) {
    v.choice("method", m.method, kFreePathMethods, "free path method");
    v.value("step_voxels", m.step_voxels);
    v.value("step_world", m.step_world);
}

template <class P, class V>
void progressive_fields(P& p, V& v) {
    v.value("iterations", p.iterations);
    v.value("time_budget", p.time_budget);
    v.value("target_relmse", p.target_relmse);
    v.value("alpha", p.alpha);
}

// ---- Reading -----------------------------------------------------------------------------------

/// M = T * Rz * Ry * Rx * S, or a row-major affine "matrix" (exclusive with the others).
Mat4 read_transform(const json& v, const std::string& file, const std::string& pointer) {
    JsonReader r(v, file, pointer);
    if (const json* m = r.find("matrix")) {
        for (const char* other : {"translate", "rotate_deg", "scale"}) {
            if (v.contains(other)) {
                r.fail(r.pointer(other), std::string("'") + other +
                                             "' cannot be combined with 'matrix'; give either a "
                                             "matrix or translate/rotate_deg/scale");
            }
        }
        if (!m->is_array() || m->size() != 16) {
            r.fail(r.pointer("matrix"),
                   "expected 16 numbers (row-major 4x4), found " + describe_json(*m));
        }
        Mat4 out(1.0f);
        for (int row = 0; row < 4; ++row) {
            for (int col = 0; col < 4; ++col) {
                const size_t i = size_t(row * 4 + col);
                out[col][row] = json_to_float(
                    (*m)[i], file, json_pointer_append(r.pointer("matrix"), std::to_string(i)));
            }
        }
        if (out[0][3] != 0.0f || out[1][3] != 0.0f || out[2][3] != 0.0f || out[3][3] != 1.0f) {
            r.fail(r.pointer("matrix"),
                   "expected an affine matrix whose last row is [0, 0, 0, 1], "
                   "found [" +
                       (*m)[12].dump() + ", " + (*m)[13].dump() + ", " + (*m)[14].dump() + ", " +
                       (*m)[15].dump() + "]");
        }
        r.finish();
        return out;
    }
    Vec3 translate(0.0f), rotate_deg(0.0f), scale(1.0f);
    r.read_vec3("translate", &translate);
    r.read_vec3("rotate_deg", &rotate_deg);
    if (const json* s = r.find("scale"))
        scale = json_to_vec3_or_number(*s, file, r.pointer("scale"));
    r.finish();
    Mat4 m = glm::translate(Mat4(1.0f), translate);
    m = glm::rotate(m, glm::radians(rotate_deg.z), Vec3(0.0f, 0.0f, 1.0f));
    m = glm::rotate(m, glm::radians(rotate_deg.y), Vec3(0.0f, 1.0f, 0.0f));
    m = glm::rotate(m, glm::radians(rotate_deg.x), Vec3(1.0f, 0.0f, 0.0f));
    return glm::scale(m, scale);
}

struct FieldReader {
    JsonReader& r;
    void vec3(const char* key, Vec3& x) { r.read_vec3(key, &x); }
    void color(const char* key, Color& x) { r.read_color(key, &x); }
    template <class T>
    void value(const char* key, T& x) {
        r.read(key, &x);
    }
    /// A key set by rule when absent: stays empty unless the scene gives it.
    template <class T>
    void value(const char* key, std::optional<T>& x) {
        if (!r.find(key)) return;
        T v{};
        r.read(key, &v);
        x = v;
    }
    template <class E, size_t N>
    void choice(const char* key, E& x, const std::array<E, N>& values, const char* what) {
        r.read_enum(key, values, what, &x);
    }
    void transform(const char* key, TransformDesc& t) {
        if (const json* v = r.find(key)) t.matrix = read_transform(*v, r.file(), r.pointer(key));
    }
    void bounds(const char* key, std::optional<Box3>& b) {
        const json* v = r.find(key);
        if (!v) return;
        JsonReader br(*v, r.file(), r.pointer(key));
        Box3 box;
        br.require("min", "[x, y, z]");
        br.require("max", "[x, y, z]");
        br.read_vec3("min", &box.lo);
        br.read_vec3("max", &box.hi);
        br.finish();
        b = box;
    }
    template <class T, class F>
    void object(const char* key, std::optional<T>& x, F fields) {
        const json* v = r.find(key);
        if (!v) return;
        JsonReader sub(*v, r.file(), r.pointer(key));
        FieldReader f{sub};
        fields(x.emplace(), f);
        sub.finish();
    }
};

/// Reads an array member; absent = empty.
template <class T, class F>
std::vector<T> read_array(JsonReader& top, const char* key, F read_one) {
    std::vector<T> out;
    const json* a = top.find(key);
    if (!a) return out;
    if (!a->is_array()) top.fail(top.pointer(key), "expected an array, found " + describe_json(*a));
    for (size_t i = 0; i < a->size(); ++i) {
        JsonReader r((*a)[i], top.file(), json_pointer_append(top.pointer(key), std::to_string(i)));
        out.push_back(read_one(r));
        r.finish();
    }
    return out;
}

/// Reads an object member through its field list; absent = defaults kept.
template <class T, class F>
void read_object(JsonReader& top, const char* key, T& x, F fields) {
    const json* v = top.find(key);
    if (!v) return;
    JsonReader r(*v, top.file(), top.pointer(key));
    FieldReader f{r};
    fields(x, f);
    r.finish();
}

// ---- Writing -----------------------------------------------------------------------------------

/// The shortest decimal that reads back as the same float, so reports show 0.8, not
/// 0.800000011920929, and from_json(to_json(x)) == x exactly.
double clean(float f) {
    char buf[32];
    for (int precision = 6; precision <= 9; ++precision) {
        std::snprintf(buf, sizeof(buf), "%.*g", precision, double(f));
        if (std::strtof(buf, nullptr) == f) break;
    }
    return std::strtod(buf, nullptr);
}

json vec_json(const Vec3& v) { return json::array({clean(v.x), clean(v.y), clean(v.z)}); }

json transform_json(const TransformDesc& t) {
    json m = json::array();
    for (int row = 0; row < 4; ++row) {
        for (int col = 0; col < 4; ++col) m.push_back(clean(t.matrix[col][row]));
    }
    return json{{"matrix", m}};
}

struct FieldWriter {
    json& j;
    void vec3(const char* key, const Vec3& x) { j[key] = vec_json(x); }
    void color(const char* key, const Color& x) { j[key] = vec_json(x); }
    void value(const char* key, float x) { j[key] = clean(x); }
    template <class T>
    void value(const char* key, const T& x) {
        j[key] = x;
    }
    template <class T>
    void value(const char* key, const std::optional<T>& x) {
        if (x) j[key] = *x;
    }
    template <class E, size_t N>
    void choice(const char* key, E x, const std::array<E, N>&, const char*) {
        j[key] = to_string(x);
    }
    void transform(const char* key, const TransformDesc& t) { j[key] = transform_json(t); }
    void bounds(const char* key, const std::optional<Box3>& b) {
        if (b) j[key] = json{{"min", vec_json(b->lo)}, {"max", vec_json(b->hi)}};
    }
    template <class T, class F>
    void object(const char* key, const std::optional<T>& x, F fields) {
        if (!x) return;
        json sub = json::object();
        FieldWriter w{sub};
        fields(*x, w);
        j[key] = sub;
    }
};

template <class T, class F>
json write_object(const T& x, F fields) {
    json j = json::object();
    FieldWriter w{j};
    fields(x, w);
    return j;
}

template <class T, class F>
json write_typed(const T& x, F fields) {
    json j = json::object();
    j["type"] = to_string(x.type);
    FieldWriter w{j};
    fields(x, w);
    return j;
}

// ---- Files and overrides -----------------------------------------------------------------------

std::vector<std::string> split_key(const std::string& key) {
    std::vector<std::string> parts;
    size_t start = 0;
    while (true) {
        const size_t dot = key.find('.', start);
        parts.push_back(key.substr(start, dot - start));
        if (dot == std::string::npos) break;
        start = dot + 1;
    }
    return parts;
}

bool is_index(const std::string& s) {
    return !s.empty() && s.size() < 10 && s.find_first_not_of("0123456789") == std::string::npos;
}

/// "/render/spp" for "render.spp=64"; "" if the assignment has no '='.
std::string override_pointer(const std::string& assignment) {
    const size_t eq = assignment.find('=');
    if (eq == std::string::npos) return "";
    std::string pointer;
    for (const auto& part : split_key(assignment.substr(0, eq))) {
        pointer = json_pointer_append(pointer, part);
    }
    return pointer;
}

}  // namespace

void apply_override(json& doc, const std::string& assignment, const std::string& file) {
    const std::string origin = "--set '" + assignment + "': ";
    const size_t eq = assignment.find('=');
    if (eq == std::string::npos) {
        throw InputError(file, "", origin + "expected key=value, e.g. render.spp=64");
    }
    const std::vector<std::string> parts = split_key(assignment.substr(0, eq));
    json* node = &doc;
    std::string pointer;
    for (const auto& part : parts) {
        if (part.empty()) {
            throw InputError(file, pointer,
                             origin +
                                 "empty key segment; expected dotted keys "
                                 "such as lights.0.intensity");
        }
        if (node->is_array()) {
            if (!is_index(part)) {
                throw InputError(file, pointer,
                                 origin + "expected an array index, found '" + part + "'");
            }
            const size_t index = std::stoul(part);
            if (index >= node->size()) {
                throw InputError(file, json_pointer_append(pointer, part),
                                 origin + "index " + part + " is out of range; the array has " +
                                     std::to_string(node->size()) + " elements");
            }
            node = &(*node)[index];
        } else if (node->is_object() || node->is_null()) {
            node = &(*node)[part];  // creates missing keys; a wrong one fails as an unknown key
        } else {
            throw InputError(file, pointer,
                             origin + "cannot set '" + part + "' inside " + describe_json(*node) +
                                 "; expected an object");
        }
        pointer = json_pointer_append(pointer, part);
    }
    const std::string text = assignment.substr(eq + 1);
    json value;
    try {
        value = json::parse(text, nullptr, false);
    } catch (const json::exception&) {
        value = json::value_t::discarded;
    }
    *node = value.is_discarded() ? json(text) : value;
}

SceneDesc scene_desc_from_json(const json& doc, const std::string& file) {
    SceneDesc desc;
    desc.path = file;
    desc.base_dir = std::filesystem::path(file).parent_path().string();
    JsonReader top(doc, file, "");
    if (doc.is_object()) check_moved_keys(doc, file);

    read_object(top, "camera", desc.camera, [](auto& x, auto& f) { camera_fields(x, f); });
    desc.lights = read_array<LightDesc>(top, "lights", [](JsonReader& r) {
        LightDesc l;
        r.read_enum("type", kLightTypes, "light type", &l.type, true);
        FieldReader f{r};
        light_fields(l, f);
        return l;
    });
    if (const json* v = top.find("materials")) {
        if (!v->is_object()) {
            top.fail(top.pointer("materials"),
                     "expected an object (name -> material), found " + describe_json(*v));
        }
        for (const auto& item : v->items()) {
            JsonReader r(item.value(), file,
                         json_pointer_append(top.pointer("materials"), item.key()));
            MaterialDesc m;
            r.read_enum("type", kMaterialTypes, "material type", &m.type, true);
            FieldReader f{r};
            material_fields(m, f);
            r.finish();
            desc.materials[item.key()] = m;
        }
    }
    desc.shapes = read_array<ShapeDesc>(top, "shapes", [&desc](JsonReader& r) {
        ShapeDesc s;
        r.read_enum("type", kShapeTypes, "shape type", &s.type, true);
        FieldReader f{r};
        shape_fields(s, f);
        if (!r.has("material")) {
            std::string known;
            for (const auto& item : desc.materials)
                known += (known.empty() ? "" : ", ") + item.first;
            r.require("material", "the name of a material in \"materials\" (" +
                                      (known.empty() ? std::string("the scene defines none")
                                                     : "defined: " + known) +
                                      ")");
        }
        return s;
    });
    desc.media = read_array<MediumDesc>(top, "media", [](JsonReader& r) {
        MediumDesc m;
        r.read_enum("type", kMediumTypes, "medium type", &m.type, true);
        FieldReader f{r};
        medium_fields(m, f);
        return m;
    });
    read_object(top, "render", desc.render, [](auto& x, auto& f) { render_fields(x, f); });
    read_object(top, "photons", desc.photons, [](auto& x, auto& f) { photon_fields(x, f); });
    read_object(top, "global", desc.global, [](auto& x, auto& f) { global_fields(x, f); });
    read_object(top, "caustic", desc.caustic, [](auto& x, auto& f) { caustic_fields(x, f); });
    read_object(top, "volume", desc.volume, [](auto& x, auto& f) { volume_fields(x, f); });
    read_object(top, "march", desc.march, [](auto& x, auto& f) { march_fields(x, f); });
    read_object(top, "advanced", desc, [](auto& x, auto& f) { advanced_fields(x, f); });
    read_object(top, "progressive", desc.progressive,
                [](auto& x, auto& f) { progressive_fields(x, f); });
    top.finish();
    return desc;
}

json to_json(const RenderSettings& render) {
    return write_object(render, [](const auto& x, FieldWriter& f) { render_fields(x, f); });
}

json settings_json(const SceneDesc& desc) {
    json j = json::object();
    j["render"] = to_json(desc.render);
    j["photons"] =
        write_object(desc.photons, [](const auto& x, FieldWriter& f) { photon_fields(x, f); });
    j["global"] =
        write_object(desc.global, [](const auto& x, FieldWriter& f) { global_fields(x, f); });
    j["caustic"] =
        write_object(desc.caustic, [](const auto& x, FieldWriter& f) { caustic_fields(x, f); });
    j["volume"] =
        write_object(desc.volume, [](const auto& x, FieldWriter& f) { volume_fields(x, f); });
    j["march"] =
        write_object(desc.march, [](const auto& x, FieldWriter& f) { march_fields(x, f); });
    j["progressive"] = write_object(
        desc.progressive, [](const auto& x, FieldWriter& f) { progressive_fields(x, f); });
    j["advanced"] =
        write_object(desc, [](const auto& x, FieldWriter& f) { advanced_fields(x, f); });
    return j;
}

json to_json(const SceneDesc& desc) {
    json j = settings_json(desc);
    j["camera"] =
        write_object(desc.camera, [](const auto& x, FieldWriter& f) { camera_fields(x, f); });

    j["lights"] = json::array();
    for (const auto& l : desc.lights) {
        j["lights"].push_back(
            write_typed(l, [](const LightDesc& x, FieldWriter& f) { light_fields(x, f); }));
    }
    j["materials"] = json::object();
    for (const auto& [name, m] : desc.materials) {
        j["materials"][name] =
            write_typed(m, [](const MaterialDesc& x, FieldWriter& f) { material_fields(x, f); });
    }
    j["shapes"] = json::array();
    for (const auto& s : desc.shapes) {
        j["shapes"].push_back(
            write_typed(s, [](const ShapeDesc& x, FieldWriter& f) { shape_fields(x, f); }));
    }
    j["media"] = json::array();
    for (const auto& m : desc.media) {
        j["media"].push_back(
            write_typed(m, [](const MediumDesc& x, FieldWriter& f) { medium_fields(x, f); }));
    }
    return j;
}

json scene_document(const std::string& path, const std::vector<std::string>& overrides, int frame) {
    json doc = is_vdb_path(path)
                   ? vdb_scene_json(path, frame)
                   : parse_json_document(
                         read_input_file(path, "", "scene file", kMaxSceneFileBytes), path);
    for (const auto& o : overrides) apply_override(doc, o, path);
    return doc;
}

SceneDesc load_scene_desc(const std::string& path, const std::vector<std::string>& overrides,
                          int frame) {
    const json doc = scene_document(path, overrides, frame);
    try {
        SceneDesc desc = scene_desc_from_json(doc, path);
        validate(desc);
        return desc;
    } catch (const InputError& e) {
        // A bad value that came from the command line says so, with the assignment.
        for (auto it = overrides.rbegin(); it != overrides.rend(); ++it) {
            const std::string pointer = override_pointer(*it);
            if (!pointer.empty() && (e.field == pointer || e.field.rfind(pointer + "/", 0) == 0)) {
                throw InputError(e.file, e.field, e.reason + " (from --set '" + *it + "')");
            }
        }
        throw;
    }
}

}  // namespace fogmap
