#include "surface/embree_scene.h"

#include <embree3/rtcore.h>

#include <mutex>
#include <stdexcept>
#include <string>

namespace fogmap {

namespace {

// Embree's error callback: remember the first error; the constructor turns it into an exception.
void on_embree_error(void* user, RTCError code, const char* str) {
    auto* message = static_cast<std::string*>(user);
    if (message->empty())
        *message = "Embree error " + std::to_string(static_cast<int>(code)) + ": " +
                   (str ? str : "(no message)");
}

}  // namespace

struct EmbreeScene::Impl {
    RTCDevice device = nullptr;
    RTCScene scene = nullptr;
    std::string error;
    unsigned sphere_geom = RTC_INVALID_GEOMETRY_ID;

    void check() const {
        if (!error.empty()) throw std::runtime_error(error);
    }
    ~Impl() {
        if (scene) rtcReleaseScene(scene);
        if (device) rtcReleaseDevice(device);
    }
};

EmbreeScene::EmbreeScene(std::vector<Mesh> meshes, std::vector<Sphere> spheres)
    : impl_(std::make_unique<Impl>()), meshes_(std::move(meshes)), spheres_(std::move(spheres)) {
    impl_->device = rtcNewDevice(nullptr);
    if (!impl_->device) throw std::runtime_error("cannot create the Embree device");
    rtcSetDeviceErrorFunction(impl_->device, on_embree_error, &impl_->error);
    impl_->scene = rtcNewScene(impl_->device);
    rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);

    normals_.resize(meshes_.size());
    for (size_t m = 0; m < meshes_.size(); ++m) {
        const Mesh& mesh = meshes_[m];
        RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
        auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0,
                                                              RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                              mesh.positions.size()));
        impl_->check();
        for (size_t i = 0; i < mesh.positions.size(); ++i) {
            v[3 * i + 0] = mesh.positions[i].x;
            v[3 * i + 1] = mesh.positions[i].y;
            v[3 * i + 2] = mesh.positions[i].z;
            bounds_.extend(mesh.positions[i]);
        }
        auto* idx = static_cast<unsigned*>(
            rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                    3 * sizeof(unsigned), mesh.triangle_count()));
        impl_->check();
        std::copy(mesh.indices.begin(), mesh.indices.end(), idx);
        normals_[m].reserve(mesh.triangle_count());
        for (size_t t = 0; t < mesh.triangle_count(); ++t) {
            const Vec3& a = mesh.positions[mesh.indices[3 * t]];
            const Vec3& b = mesh.positions[mesh.indices[3 * t + 1]];
            const Vec3& c = mesh.positions[mesh.indices[3 * t + 2]];
            const Vec3 n = glm::cross(b - a, c - a);
            const float len = glm::length(n);
            normals_[m].push_back(len > 0.0f ? n / len : Vec3(0.0f, 0.0f, 1.0f));
        }
        rtcCommitGeometry(geom);
        const unsigned id = rtcAttachGeometry(impl_->scene, geom);
        rtcReleaseGeometry(geom);
        if (id != m) throw std::runtime_error("unexpected Embree geometry id");
    }
    if (!spheres_.empty()) {
        RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
        auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0,
                                                              RTC_FORMAT_FLOAT4, 4 * sizeof(float),
                                                              spheres_.size()));
        impl_->check();
        for (size_t i = 0; i < spheres_.size(); ++i) {
            v[4 * i + 0] = spheres_[i].center.x;
            v[4 * i + 1] = spheres_[i].center.y;
            v[4 * i + 2] = spheres_[i].center.z;
            v[4 * i + 3] = spheres_[i].radius;
            bounds_.extend(spheres_[i].center - Vec3(spheres_[i].radius));
            bounds_.extend(spheres_[i].center + Vec3(spheres_[i].radius));
        }
        rtcCommitGeometry(geom);
        impl_->sphere_geom = rtcAttachGeometry(impl_->scene, geom);
        rtcReleaseGeometry(geom);
    }
    rtcCommitScene(impl_->scene);
    impl_->check();
}

EmbreeScene::~EmbreeScene() = default;

size_t EmbreeScene::triangle_count() const {
    size_t n = 0;
    for (const Mesh& m : meshes_) n += m.triangle_count();
    return n;
}

namespace {

void fill_ray(RTCRay& r, const Ray& ray, float t_min, float t_max) {
    r.org_x = ray.o.x;
    r.org_y = ray.o.y;
    r.org_z = ray.o.z;
    r.dir_x = ray.d.x;
    r.dir_y = ray.d.y;
    r.dir_z = ray.d.z;
    r.tnear = t_min;
    r.tfar = t_max;
    r.time = 0.0f;
    r.mask = 0xFFFFFFFFu;
    r.id = 0;
    r.flags = 0;
}

}  // namespace

std::optional<SurfaceHit> EmbreeScene::intersect(const Ray& ray, float t_min, float t_max) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRayHit rh;
    fill_ray(rh.ray, ray, t_min, t_max);
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(impl_->scene, &context, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
    SurfaceHit hit;
    hit.t = rh.ray.tfar;
    hit.p = ray.at(hit.t);
    if (rh.hit.geomID == impl_->sphere_geom) {
        const Sphere& s = spheres_[rh.hit.primID];
        hit.ng = glm::normalize(hit.p - s.center);
        // Project onto the surface: the float hit point can sit slightly inside or outside.
        hit.p = s.center + s.radius * hit.ng;
        hit.material = s.material;
    } else {
        const Mesh& m = meshes_[rh.hit.geomID];
        hit.ng = normals_[rh.hit.geomID][rh.hit.primID];
        hit.material = m.material;
        hit.light = m.light;
    }
    return hit;
}

bool EmbreeScene::occluded(const Ray& ray, float t_min, float t_max) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRay r;
    fill_ray(r, ray, t_min, t_max);
    rtcOccluded1(impl_->scene, &context, &r);
    return r.tfar < 0.0f;
}

}  // namespace fogmap
