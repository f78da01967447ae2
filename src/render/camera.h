#pragma once
// Pinhole camera: vertical field of view, square pixels, row 0 at the top. Immutable; thread-safe.

#include "core/math.h"
#include "scene/scene_desc.h"

namespace fogmap {

class Camera {
public:
    explicit Camera(const CameraDesc& d) : desc_(d), origin_(d.position) {
        forward_ = glm::normalize(d.look_at - d.position);
        right_ = glm::normalize(glm::cross(forward_, d.up));
        up_ = glm::cross(right_, forward_);
        tan_half_ = std::tan(0.5f * d.fov_deg * kPi / 180.0f);
        aspect_ = static_cast<float>(d.width) / static_cast<float>(d.height);
    }
    /// Unit-direction primary ray through film position (px, py) in pixels, (0,0) = top left.
    Ray generate(float px, float py) const {
        const float sx = (2.0f * px / desc_.width - 1.0f) * tan_half_ * aspect_;
        const float sy = (1.0f - 2.0f * py / desc_.height) * tan_half_;
        return Ray{origin_, glm::normalize(forward_ + sx * right_ + sy * up_)};
    }
    int width() const { return desc_.width; }
    int height() const { return desc_.height; }
    /// Motion blur's shutter, if any.
    const std::optional<ShutterDesc>& shutter() const { return desc_.shutter; }

private:
    CameraDesc desc_;
    Vec3 origin_, forward_, right_, up_;
    float tan_half_ = 1.0f, aspect_ = 1.0f;
};

}  // namespace fogmap
