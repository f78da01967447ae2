#include "surface/mesh.h"

#include "core/error.h"
#include "core/input_file.h"

#include <tiny_obj_loader.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <sstream>

namespace fogmap {

namespace {

// Corners of the box are numbered by bits: bit 0 = x, bit 1 = y, bit 2 = z (0 = min, 1 = max).
// Each face lists its corners counter-clockwise seen from outside (u x v points outwards).
constexpr int kBoxFaces[6][4] = {
    {0, 4, 6, 2},  // -x
    {1, 3, 7, 5},  // +x
    {0, 1, 5, 4},  // -y
    {2, 6, 7, 3},  // +y
    {0, 2, 3, 1},  // -z
    {4, 5, 7, 6},  // +z
};

/// A transform with a negative determinant mirrors the geometry, which turns counter-clockwise
/// triangles clockwise; swapping two indices keeps the front side the same.
void transform_mesh(Mesh* mesh, const Mat4& m) {
    for (auto& p : mesh->positions) p = transform_point(m, p);
    if (glm::determinant(Mat3(m)) < 0.0f) {
        for (size_t t = 0; t + 2 < mesh->indices.size(); t += 3) {
            std::swap(mesh->indices[t + 1], mesh->indices[t + 2]);
        }
    }
}

/// Fan triangulation of a convex polygon: (0, i, i+1).
void add_polygon(Mesh* mesh, const std::vector<uint32_t>& polygon) {
    for (size_t i = 1; i + 1 < polygon.size(); ++i) {
        mesh->indices.insert(mesh->indices.end(), {polygon[0], polygon[i], polygon[i + 1]});
    }
}

std::string read_file(const std::string& path, const std::string& field) {
    return read_input_file(path, field, "mesh file", kMaxMeshFileBytes);
}

// ---- OBJ ---------------------------------------------------------------------------------------

/// tinyobjloader reads the words nan and inf in a vertex as 0 or a huge finite number: a vertex
/// line holding one is refused here instead of silently moved.
void check_obj_numbers(const std::string& text, const std::string& path, const std::string& field) {
    size_t line = 1, vertex = 0;
    for (size_t at = 0; at < text.size(); ++line) {
        const size_t end = std::min(text.find('\n', at), text.size());
        if (text.compare(at, 2, "v ") == 0 || text.compare(at, 2, "v\t") == 0) {
            ++vertex;
            std::string l = text.substr(at, end - at);
            for (char& c : l) c = char(std::tolower(static_cast<unsigned char>(c)));
            if (l.find("nan") != std::string::npos || l.find("inf") != std::string::npos)
                throw InputError(path, field,
                                 "vertex " + std::to_string(vertex) + " (line " +
                                     std::to_string(line) +
                                     ") has a non-finite coordinate; expected finite numbers");
        }
        at = end + 1;
    }
}

Mesh load_obj(const std::string& path, const std::string& field) {
    const std::string text = read_file(path, field);
    check_obj_numbers(text, path, field);
    tinyobj::ObjReaderConfig config;
    config.triangulate = false;  // fan-triangulated below, the same rule as PLY
    config.vertex_color = false;
    tinyobj::ObjReader reader;
    if (!reader.ParseFromString(text, "", config)) {
        std::string err = reader.Error();
        while (!err.empty() && std::isspace(static_cast<unsigned char>(err.back()))) err.pop_back();
        throw InputError(path, field, "invalid OBJ: " + err);
    }
    Mesh mesh;
    const auto& v = reader.GetAttrib().vertices;
    for (size_t i = 0; i + 2 < v.size(); i += 3) {
        mesh.positions.emplace_back(float(v[i]), float(v[i + 1]), float(v[i + 2]));
        const Vec3& p = mesh.positions.back();
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
            throw InputError(path, field,
                             "vertex " + std::to_string(i / 3 + 1) +
                                 " has a non-finite coordinate (NaN, infinite, or beyond a float)");
    }
    std::vector<uint32_t> polygon;
    for (const auto& shape : reader.GetShapes()) {
        size_t offset = 0;
        for (size_t f = 0; f < shape.mesh.num_face_vertices.size(); ++f) {
            const size_t n = shape.mesh.num_face_vertices[f];
            polygon.clear();
            for (size_t k = 0; k < n; ++k) {
                const int index = shape.mesh.indices[offset + k].vertex_index;
                if (index < 0 || size_t(index) >= mesh.positions.size()) {
                    throw InputError(path, field,
                                     "face " + std::to_string(f) +
                                         (shape.name.empty() ? "" : " of '" + shape.name + "'") +
                                         " refers to vertex " + std::to_string(index + 1) +
                                         "; the file has " + std::to_string(mesh.positions.size()) +
                                         " vertices");
                }
                polygon.push_back(uint32_t(index));
            }
            add_polygon(&mesh, polygon);
            offset += n;
        }
    }
    return mesh;
}

// ---- PLY ---------------------------------------------------------------------------------------

enum class PlyFormat { Ascii, BinaryLittleEndian, BinaryBigEndian };
enum class PlyType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

struct PlyProperty {
    std::string name;
    PlyType type = PlyType::Float32;  ///< value type (list: element type)
    bool is_list = false;
    PlyType count_type = PlyType::UInt8;  ///< list only
};

struct PlyElement {
    std::string name;
    size_t count = 0;
    std::vector<PlyProperty> properties;
};

bool parse_ply_type(const std::string& s, PlyType* t) {
    static const struct {
        const char* name;
        PlyType type;
    } kTypes[] = {
        {"char", PlyType::Int8},      {"int8", PlyType::Int8},       {"uchar", PlyType::UInt8},
        {"uint8", PlyType::UInt8},    {"short", PlyType::Int16},     {"int16", PlyType::Int16},
        {"ushort", PlyType::UInt16},  {"uint16", PlyType::UInt16},   {"int", PlyType::Int32},
        {"int32", PlyType::Int32},    {"uint", PlyType::UInt32},     {"uint32", PlyType::UInt32},
        {"float", PlyType::Float32},  {"float32", PlyType::Float32}, {"double", PlyType::Float64},
        {"float64", PlyType::Float64}};
    for (const auto& entry : kTypes) {
        if (s == entry.name) {
            *t = entry.type;
            return true;
        }
    }
    return false;
}

size_t ply_size(PlyType t) {
    switch (t) {
        case PlyType::Int8:
        case PlyType::UInt8:
            return 1;
        case PlyType::Int16:
        case PlyType::UInt16:
            return 2;
        case PlyType::Int32:
        case PlyType::UInt32:
        case PlyType::Float32:
            return 4;
        case PlyType::Float64:
            return 8;
    }
    return 0;
}

std::string num(double x) {
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%.17g", x);
    return buf;
}

bool host_is_little_endian() {
    const uint16_t one = 1;
    unsigned char first = 0;
    std::memcpy(&first, &one, 1);
    return first == 1;
}

/// Reads the values of the body one at a time, in the file's format. `context` names the
/// element row being read, for messages.
class PlyBody {
public:
    PlyBody(const std::string& data, size_t pos, PlyFormat format, const std::string& path,
            const std::string& field)
        : data_(data),
          pos_(pos),
          format_(format),
          path_(path),
          field_(field),
          swap_(format != PlyFormat::Ascii &&
                (format == PlyFormat::BinaryLittleEndian) != host_is_little_endian()) {}

    std::string context;

    double next(PlyType t) { return format_ == PlyFormat::Ascii ? next_ascii() : next_binary(t); }

private:
    [[noreturn]] void truncated() const {
        throw InputError(path_, field_, "truncated file: the data ends inside " + context);
    }

    double next_ascii() {
        while (pos_ < data_.size() && std::isspace(static_cast<unsigned char>(data_[pos_]))) {
            ++pos_;
        }
        if (pos_ >= data_.size()) truncated();
        const size_t start = pos_;
        while (pos_ < data_.size() && !std::isspace(static_cast<unsigned char>(data_[pos_]))) {
            ++pos_;
        }
        const std::string token = data_.substr(start, pos_ - start);
        char* end = nullptr;
        const double x = std::strtod(token.c_str(), &end);
        if (end != token.c_str() + token.size()) {
            throw InputError(path_, field_,
                             "expected a number in " + context + ", found '" + token + "'");
        }
        return x;
    }

    double next_binary(PlyType t) {
        const size_t n = ply_size(t);
        if (data_.size() - pos_ < n) truncated();
        unsigned char b[8];
        std::memcpy(b, data_.data() + pos_, n);
        pos_ += n;
        if (swap_) std::reverse(b, b + n);
        switch (t) {
            case PlyType::Int8:
                return double(load<int8_t>(b));
            case PlyType::UInt8:
                return double(load<uint8_t>(b));
            case PlyType::Int16:
                return double(load<int16_t>(b));
            case PlyType::UInt16:
                return double(load<uint16_t>(b));
            case PlyType::Int32:
                return double(load<int32_t>(b));
            case PlyType::UInt32:
                return double(load<uint32_t>(b));
            case PlyType::Float32:
                return double(load<float>(b));
            case PlyType::Float64:
                return load<double>(b);
        }
        return 0.0;
    }

    template <class T>
    static T load(const unsigned char* b) {
        T x;
        std::memcpy(&x, b, sizeof(T));
        return x;
    }

    const std::string& data_;
    size_t pos_;
    PlyFormat format_;
    const std::string& path_;
    const std::string& field_;
    bool swap_;
};

struct PlyHeader {
    PlyFormat format = PlyFormat::Ascii;
    std::vector<PlyElement> elements;
    size_t body = 0;  ///< byte offset of the first byte after "end_header\n"
};

PlyHeader parse_ply_header(const std::string& data, const std::string& path,
                           const std::string& field) {
    auto fail = [&](const std::string& reason) { throw InputError(path, field, reason); };
    PlyHeader header;
    size_t pos = 0;
    bool have_format = false;
    for (int line_no = 1;; ++line_no) {
        const size_t eol = data.find('\n', pos);
        if (eol == std::string::npos) fail("invalid PLY: the header has no end_header line");
        std::string line = data.substr(pos, eol - pos);
        pos = eol + 1;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        std::istringstream in(line);
        std::string word;
        in >> word;
        const std::string where =
            "invalid PLY header line " + std::to_string(line_no) + " '" + line + "': ";
        if (line_no == 1) {
            if (word != "ply") fail("not a PLY file: the first line is not 'ply'");
            continue;
        }
        if (word == "end_header") break;
        if (word.empty() || word == "comment" || word == "obj_info") continue;
        if (word == "format") {
            std::string kind;
            in >> kind;
            if (kind == "ascii") {
                header.format = PlyFormat::Ascii;
            } else if (kind == "binary_little_endian") {
                header.format = PlyFormat::BinaryLittleEndian;
            } else if (kind == "binary_big_endian") {
                header.format = PlyFormat::BinaryBigEndian;
            } else {
                fail(where + "unknown format '" + kind +
                     "'; expected one of: ascii, "
                     "binary_little_endian, binary_big_endian");
            }
            have_format = true;
        } else if (word == "element") {
            PlyElement e;
            long long count = -1;
            if (!(in >> e.name >> count) || count < 0)
                fail(where + "expected 'element NAME COUNT'");
            e.count = size_t(count);
            header.elements.push_back(e);
        } else if (word == "property") {
            if (header.elements.empty()) fail(where + "property before any element");
            PlyProperty p;
            std::string type;
            in >> type;
            if (type == "list") {
                std::string count_type, value_type;
                in >> count_type >> value_type;
                p.is_list = true;
                if (!parse_ply_type(count_type, &p.count_type) ||
                    !parse_ply_type(value_type, &p.type)) {
                    fail(where + "unknown list types; expected numeric types such as uchar int");
                }
            } else if (!parse_ply_type(type, &p.type)) {
                fail(where + "unknown property type '" + type +
                     "'; expected one of: char, "
                     "uchar, short, ushort, int, uint, float, double (or int8 ... "
                     "float64)");
            }
            if (!(in >> p.name)) fail(where + "the property has no name");
            header.elements.back().properties.push_back(p);
        } else {
            fail(where + "unknown keyword '" + word + "'");
        }
    }
    if (!have_format) fail("invalid PLY: the header has no format line");
    header.body = pos;
    return header;
}

int find_property(const PlyElement& e, const char* name, bool list) {
    for (size_t i = 0; i < e.properties.size(); ++i) {
        if (e.properties[i].name == name && e.properties[i].is_list == list) return int(i);
    }
    return -1;
}

Mesh load_ply(const std::string& path, const std::string& field) {
    const std::string data = read_file(path, field);
    const PlyHeader header = parse_ply_header(data, path, field);
    auto fail = [&](const std::string& reason) { throw InputError(path, field, reason); };

    Mesh mesh;
    bool have_faces = false;
    PlyBody body(data, header.body, header.format, path, field);
    std::vector<double> row;  // scalar properties of one row; lists go to `list`
    std::vector<uint32_t> polygon;
    for (const PlyElement& e : header.elements) {
        const bool is_vertex = e.name == "vertex";
        const bool is_face = e.name == "face";
        int xyz[3] = {-1, -1, -1};
        int indices = -1;
        if (is_vertex) {
            const char* names[3] = {"x", "y", "z"};
            for (int a = 0; a < 3; ++a) {
                xyz[a] = find_property(e, names[a], false);
                if (xyz[a] < 0) {
                    fail(std::string("invalid PLY: element 'vertex' has no scalar property '") +
                         names[a] + "'; expected x, y, z");
                }
            }
        }
        if (is_face) {
            indices = find_property(e, "vertex_indices", true);
            if (indices < 0) indices = find_property(e, "vertex_index", true);
            if (indices < 0) {
                fail(
                    "invalid PLY: element 'face' has no list property 'vertex_indices' or "
                    "'vertex_index'");
            }
            have_faces = true;
        }
        row.assign(e.properties.size(), 0.0);
        for (size_t r = 0; r < e.count; ++r) {
            body.context = "element '" + e.name + "' row " + std::to_string(r) + " of " +
                           std::to_string(e.count);
            for (size_t p = 0; p < e.properties.size(); ++p) {
                const PlyProperty& prop = e.properties[p];
                if (!prop.is_list) {
                    row[p] = body.next(prop.type);
                    continue;
                }
                const double n = body.next(prop.count_type);
                if (n < 0 || std::floor(n) != n)
                    fail("invalid PLY: " + body.context + " has a list length of " + num(n));
                const bool keep = int(p) == indices;
                if (keep && n < 3) {
                    fail("invalid PLY: face " + std::to_string(r) + " has " +
                         std::to_string(size_t(n)) + " vertices; expected at least 3");
                }
                polygon.clear();
                for (size_t k = 0; k < size_t(n); ++k) {
                    const double index = body.next(prop.type);
                    if (!keep) continue;
                    // Checked against the vertex count below, once all elements are read.
                    if (index < 0 || std::floor(index) != index || index > 4294967295.0) {
                        fail("face " + std::to_string(r) + " refers to vertex " + num(index) +
                             ", which is out of range");
                    }
                    polygon.push_back(uint32_t(index));
                }
                if (keep) add_polygon(&mesh, polygon);
            }
            if (is_vertex) {
                // Braces: with parentheses clang parses this as a function declaration.
                const Vec3 p{float(row[size_t(xyz[0])]), float(row[size_t(xyz[1])]),
                             float(row[size_t(xyz[2])])};
                if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
                    fail("vertex " + std::to_string(r) + " has a non-finite coordinate");
                }
                mesh.positions.push_back(p);
            }
        }
    }
    if (!have_faces) fail("invalid PLY: no 'face' element; expected a triangle mesh");
    for (size_t i = 0; i < mesh.indices.size(); ++i) {
        if (mesh.indices[i] >= mesh.positions.size()) {
            fail("face triangle " + std::to_string(i / 3) + " refers to vertex " +
                 std::to_string(mesh.indices[i]) + "; the file has " +
                 std::to_string(mesh.positions.size()) + " vertices");
        }
    }
    return mesh;
}

}  // namespace

Mesh make_quad(const Vec3& corner, const Vec3& u, const Vec3& v) {
    Mesh mesh;
    mesh.positions = {corner, corner + u, corner + u + v, corner + v};
    mesh.indices = {0, 1, 2, 0, 2, 3};
    return mesh;
}

Mesh make_box(const Vec3& min, const Vec3& max, const Mat4& m) {
    Mesh mesh;
    for (int c = 0; c < 8; ++c) {
        mesh.positions.emplace_back(c & 1 ? max.x : min.x, c & 2 ? max.y : min.y,
                                    c & 4 ? max.z : min.z);
    }
    for (const auto& face : kBoxFaces) {
        add_polygon(&mesh,
                    {uint32_t(face[0]), uint32_t(face[1]), uint32_t(face[2]), uint32_t(face[3])});
    }
    transform_mesh(&mesh, m);
    return mesh;
}

Mesh load_mesh(const std::string& path, const Mat4& m, const std::string& field) {
    std::string ext = std::filesystem::path(path).extension().string();
    for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    Mesh mesh;
    if (ext == ".obj") {
        mesh = load_obj(path, field);
    } else if (ext == ".ply") {
        mesh = load_ply(path, field);
    } else {
        throw InputError(path, field,
                         "unknown mesh file extension '" + ext + "'; expected one of: .obj, .ply");
    }
    if (mesh.indices.empty()) throw InputError(path, field, "the mesh has no faces");
    transform_mesh(&mesh, m);
    return mesh;
}

}  // namespace fogmap
