#pragma once
// Triangle meshes and analytic spheres as handed to Embree, in world space. Plain data.

#include "core/math.h"

#include <cstdint>
#include <string>
#include <vector>

namespace fogmap {

struct Mesh {
    std::vector<Vec3> positions;    ///< world space
    std::vector<uint32_t> indices;  ///< 3 per triangle, counter-clockwise seen from the front
    int material = -1;              ///< index into Scene::materials
    int light = -1;                 ///< index into Scene::lights when this mesh emits (quad light)
    size_t triangle_count() const { return indices.size() / 3; }
};

struct Sphere {
    Vec3 center{0.0f};
    float radius = 1.0f;
    int material = -1;
};

/// Two triangles spanning corner, corner+u, corner+u+v, corner+v; front side faces u x v.
Mesh make_quad(const Vec3& corner, const Vec3& u, const Vec3& v);
/// Twelve triangles of the box [min, max] transformed by m, outward-facing.
Mesh make_box(const Vec3& min, const Vec3& max, const Mat4& m);

/// Loads a triangle mesh (polygons fan-triangulated) from an OBJ or PLY (ascii or
/// binary_little_endian / binary_big_endian; vertex x,y,z and a face list) file, by extension,
/// and applies m. Throws InputError{path, field, reason} for a missing, unreadable or malformed
/// file, an unknown extension, or an index out of range; `field` is the JSON pointer of the
/// scene entry that named the file.
Mesh load_mesh(const std::string& path, const Mat4& m, const std::string& field);

}  // namespace fogmap
