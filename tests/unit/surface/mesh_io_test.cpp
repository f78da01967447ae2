#include "surface/mesh.h"

#include "core/error.h"
#include "test_support.h"

#include <gtest/gtest.h>
#include <glm/gtc/matrix_transform.hpp>

#include <unistd.h>
#include <algorithm>
#include <array>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

namespace fogmap {
namespace {

using test::catch_input_error;

/// A temp folder per test, removed at the end.
struct TempDir : test::TempDir {
    TempDir() : test::TempDir("fogmap_mesh") {}
    std::string path() const { return test::TempDir::path().string(); }
};

/// Signed volume enclosed by a closed, consistently wound mesh: by the divergence theorem, the
/// sum over triangles of the signed tetrahedron volumes a . (b x c) / 6 (positive = outward).
double enclosed_volume(const Mesh& m) {
    double v = 0.0;
    for (size_t t = 0; t < m.triangle_count(); ++t) {
        const DVec3 a(m.positions[m.indices[3 * t]]);
        const DVec3 b(m.positions[m.indices[3 * t + 1]]);
        const DVec3 c(m.positions[m.indices[3 * t + 2]]);
        v += glm::dot(a, glm::cross(b, c)) / 6.0;
    }
    return v;
}

/// Every triangle's normal points away from `inside` (true for a convex shape around it).
void expect_outward(const Mesh& m, const Vec3& inside) {
    for (size_t t = 0; t < m.triangle_count(); ++t) {
        const Vec3 a = m.positions[m.indices[3 * t]];
        const Vec3 b = m.positions[m.indices[3 * t + 1]];
        const Vec3 c = m.positions[m.indices[3 * t + 2]];
        const Vec3 n = glm::cross(b - a, c - a);
        EXPECT_GT(glm::dot(n, (a + b + c) / 3.0f - inside), 0.0f) << "triangle " << t;
    }
}

/// The triangles as position triples, to compare meshes independently of vertex sharing.
std::vector<std::array<Vec3, 3>> triangles(const Mesh& m) {
    std::vector<std::array<Vec3, 3>> out;
    for (size_t t = 0; t < m.triangle_count(); ++t) {
        out.push_back({m.positions[m.indices[3 * t]], m.positions[m.indices[3 * t + 1]],
                       m.positions[m.indices[3 * t + 2]]});
    }
    return out;
}

TEST(MakeBox, TwelveOutwardTrianglesEncloseTheBoxVolume) {
    const Vec3 lo(-1.0f, 0.5f, 2.0f), hi(2.0f, 1.5f, 4.5f);  // 3 x 1 x 2.5 = 7.5
    const Mesh box = make_box(lo, hi, Mat4(1.0f));
    EXPECT_EQ(box.triangle_count(), 12u);
    EXPECT_NEAR(enclosed_volume(box), 7.5, 1e-5);
    expect_outward(box, 0.5f * (lo + hi));
    const Box3 bounds{lo, hi};
    for (const Vec3& p : box.positions) EXPECT_TRUE(bounds.contains(p));
}

TEST(MakeBox, TransformScalesVolumeByDeterminantAndKeepsOutwardFaces) {
    const Vec3 lo(0.0f), hi(1.0f, 2.0f, 3.0f);  // volume 6
    Mat4 m = glm::translate(Mat4(1.0f), Vec3(5.0f, -2.0f, 1.0f));
    m = glm::rotate(m, 0.7f, glm::normalize(Vec3(1.0f, 2.0f, 3.0f)));
    m = glm::scale(m, Vec3(2.0f, 0.5f, 3.0f));  // determinant 3
    const Mesh box = make_box(lo, hi, m);
    EXPECT_NEAR(enclosed_volume(box), 18.0, 1e-4);
    expect_outward(box, transform_point(m, 0.5f * (lo + hi)));

    // A mirror (negative determinant) must not turn the box inside out.
    const Mat4 mirror = glm::scale(Mat4(1.0f), Vec3(-1.0f, 1.0f, 1.0f));
    const Mesh mirrored = make_box(lo, hi, mirror);
    EXPECT_NEAR(enclosed_volume(mirrored), 6.0, 1e-5);
    expect_outward(mirrored, transform_point(mirror, 0.5f * (lo + hi)));
}

TEST(MakeQuad, FrontFacesUCrossVWithTheRightArea) {
    const Vec3 corner(1.0f, 2.0f, 3.0f), u(2.0f, 0.0f, 0.0f), v(0.0f, 0.0f, -3.0f);
    const Mesh q = make_quad(corner, u, v);
    ASSERT_EQ(q.triangle_count(), 2u);
    float area = 0.0f;
    for (const auto& t : triangles(q)) {
        const Vec3 n = glm::cross(t[1] - t[0], t[2] - t[0]);
        EXPECT_GT(glm::dot(n, glm::cross(u, v)), 0.0f);
        area += 0.5f * glm::length(n);
    }
    EXPECT_FLOAT_EQ(area, 6.0f);
}

// The same unit quad in every format: four corners, one polygon, plus properties and elements
// a loader has to skip.
const Vec3 kCorners[4] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0.5f}, {0, 1, 0.5f}};

std::string quad_obj() {
    return "# quad\nmtllib missing.mtl\no quad\n"
           "v 0 0 0\nv 1 0 0\nv 1 1 0.5\nv 0 1 0.5\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\n";
}

std::string quad_ply_ascii() {
    return "ply\nformat ascii 1.0\ncomment made by a test\n"
           "element vertex 4\nproperty float x\nproperty double nx\nproperty float y\n"
           "property float z\nproperty uchar red\n"
           "element face 1\nproperty list uchar int vertex_indices\n"
           "element edge 1\nproperty list uint short ids\nend_header\n"
           "0 9 0 0 255\n1 9 0 0 255\n1 9 1 0.5 255\n0 9 1 0.5 255\n4 0 1 2 3\n2 0 1\n";
}

template <class T>
void put(std::string* out, T x, bool big_endian) {
    unsigned char b[sizeof(T)];
    std::memcpy(b, &x, sizeof(T));
    if (big_endian) std::reverse(b, b + sizeof(T));  // the test machine is little-endian
    out->append(reinterpret_cast<const char*>(b), sizeof(T));
}

std::string quad_ply_binary(bool big_endian) {
    std::string s = std::string("ply\nformat ") +
                    (big_endian ? "binary_big_endian" : "binary_little_endian") +
                    " 1.0\nelement vertex 4\nproperty double x\nproperty short flags\n"
                    "property float y\nproperty float z\nelement face 1\n"
                    "property list uchar uint vertex_index\nend_header\n";
    for (const Vec3& p : kCorners) {
        put(&s, double(p.x), big_endian);
        put(&s, int16_t(-7), big_endian);
        put(&s, p.y, big_endian);
        put(&s, p.z, big_endian);
    }
    put(&s, uint8_t(4), big_endian);
    for (uint32_t i = 0; i < 4; ++i) put(&s, i, big_endian);
    return s;
}

TEST(LoadMesh, ObjAndPlyQuadsGiveTheSameTriangles) {
    TempDir dir;
    // Fan triangulation of the polygon 0 1 2 3: (0, 1, 2) and (0, 2, 3).
    const std::vector<std::array<Vec3, 3>> expected = {{kCorners[0], kCorners[1], kCorners[2]},
                                                       {kCorners[0], kCorners[2], kCorners[3]}};
    const std::string files[] = {
        dir.write("quad.obj", quad_obj()),
        dir.write("quad.ply", quad_ply_ascii()),
        dir.write("quad_le.PLY", quad_ply_binary(false)),
        dir.write("quad_be.ply", quad_ply_binary(true)),
    };
    for (const std::string& f : files) {
        const Mesh m = load_mesh(f, Mat4(1.0f), "/shapes/0/file");
        EXPECT_EQ(triangles(m), expected) << f;
    }
}

TEST(LoadMesh, AppliesTheTransformToPositions) {
    TempDir dir;
    const std::string f = dir.write("quad.ply", quad_ply_ascii());
    const Mat4 m = glm::scale(glm::translate(Mat4(1.0f), Vec3(0.0f, 0.0f, 10.0f)), Vec3(2.0f));
    const Mesh mesh = load_mesh(f, m, "/shapes/0/file");
    ASSERT_EQ(mesh.positions.size(), 4u);
    EXPECT_EQ(mesh.positions[2], Vec3(2.0f, 2.0f, 11.0f));
}

TEST(LoadMesh, TruncatedPlyThrowsInputError) {
    TempDir dir;
    const std::string full = quad_ply_binary(false);
    const std::string f = dir.write("cut.ply", full.substr(0, full.size() - 3));
    const InputError e = catch_input_error([&] { load_mesh(f, Mat4(1.0f), "/shapes/2/file"); });
    EXPECT_EQ(e.file, f);
    EXPECT_EQ(e.field, "/shapes/2/file");
    EXPECT_EQ(e.reason, "truncated file: the data ends inside element 'face' row 0 of 1");

    const std::string ascii = quad_ply_ascii();
    const std::string g = dir.write("cut_ascii.ply", ascii.substr(0, ascii.find("4 0 1 2 3")));
    const InputError a = catch_input_error([&] { load_mesh(g, Mat4(1.0f), "/shapes/2/file"); });
    EXPECT_EQ(a.reason, "truncated file: the data ends inside element 'face' row 0 of 1");

    const std::string h = dir.write("no_end.ply", "ply\nformat ascii 1.0\nelement vertex 1\n");
    const InputError n = catch_input_error([&] { load_mesh(h, Mat4(1.0f), "/shapes/2/file"); });
    EXPECT_EQ(n.reason, "invalid PLY: the header has no end_header line");
}

TEST(LoadMesh, IndexOutOfRangeThrowsInputError) {
    TempDir dir;
    std::string ply = quad_ply_ascii();
    ply.replace(ply.find("4 0 1 2 3"), 9, "4 0 1 2 4");
    const std::string f = dir.write("bad.ply", ply);
    const InputError e = catch_input_error([&] { load_mesh(f, Mat4(1.0f), "/shapes/1/file"); });
    EXPECT_EQ(e.field, "/shapes/1/file");
    EXPECT_EQ(e.reason, "face triangle 1 refers to vertex 4; the file has 4 vertices");

    const std::string g = dir.write("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 5\n");
    const InputError o = catch_input_error([&] { load_mesh(g, Mat4(1.0f), "/shapes/1/file"); });
    EXPECT_EQ(o.file, g);
    EXPECT_EQ(o.field, "/shapes/1/file");
}

TEST(LoadMesh, UnknownExtensionListsObjAndPly) {
    TempDir dir;
    const std::string f = dir.write("quad.stl", "solid x\n");
    const InputError e = catch_input_error([&] { load_mesh(f, Mat4(1.0f), "/shapes/0/file"); });
    EXPECT_EQ(e.reason, "unknown mesh file extension '.stl'; expected one of: .obj, .ply");
}

TEST(LoadMesh, MissingFileSaysCannotOpen) {
    TempDir dir;
    const std::string f = dir.path() + "/absent.obj";
    const InputError e = catch_input_error([&] { load_mesh(f, Mat4(1.0f), "/shapes/0/file"); });
    EXPECT_EQ(e.file, f);
    EXPECT_EQ(e.reason, "cannot open file: No such file or directory");
}

TEST(LoadMesh, PlyWithoutCoordinatesOrFacesIsRejected) {
    TempDir dir;
    std::string no_z = quad_ply_ascii();
    no_z.replace(no_z.find("property float z"), 16, "property float w");
    const std::string f = dir.write("no_z.ply", no_z);
    EXPECT_EQ(catch_input_error([&] { load_mesh(f, Mat4(1.0f), "/s"); }).reason,
              "invalid PLY: element 'vertex' has no scalar property 'z'; expected x, y, z");

    const std::string g = dir.write("points.ply",
                                    "ply\nformat ascii 1.0\nelement vertex 1\n"
                                    "property float x\nproperty float y\n"
                                    "property float z\nend_header\n0 0 0\n");
    EXPECT_EQ(catch_input_error([&] { load_mesh(g, Mat4(1.0f), "/s"); }).reason,
              "invalid PLY: no 'face' element; expected a triangle mesh");
}

}  // namespace
}  // namespace fogmap
