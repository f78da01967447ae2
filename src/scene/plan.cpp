#include "scene/plan.h"

#include "scene/scene.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <utility>

namespace fogmap {

void describe_volume_light(const Scene& scene, PlanItem* item) {
    auto join = [](const std::vector<std::string>& lines) {
        std::string s;
        for (const std::string& l : lines) s += (s.empty() ? "" : "; ") + l;
        return s;
    };
    if (item->on && !scene.emitters.empty()) {
        item->reason = join(scene.emitters);
    } else if (!item->on && !scene.emission_hints.empty()) {
        item->reason += "; " + join(scene.emission_hints) +
                        ": add \"emission\": {} to the medium to make it glow";
    }
}

std::string plan_text(const Plan& plan) {
    const auto line = [](const char* name, const PlanItem& item, const char* on_word) {
        return std::string(name) + ": " + (item.on ? on_word : "skipped") + " (" + item.reason +
               ")\n";
    };
    return std::string("integrator: ") + plan.integrator_name + " (" + plan.integrator.reason +
           ")\n" + line("Embree scene", plan.embree_scene, "built") +
           line("ray marching", plan.ray_marching, "used") +
           line("volume light", plan.volume_light, "built") +
           line("volume map", plan.volume_map, "built") +
           line("global map", plan.global_map, "built") +
           line("caustic map", plan.caustic_map, "built");
}

nlohmann::json plan_json(const Plan& plan) {
    const auto item = [](const PlanItem& i) {
        return nlohmann::json{{"on", i.on}, {"reason", i.reason}};
    };
    return nlohmann::json{
        {"integrator", {{"name", plan.integrator_name}, {"reason", plan.integrator.reason}}},
        {"embree_scene", item(plan.embree_scene)},
        {"ray_marching", item(plan.ray_marching)},
        {"volume_light", item(plan.volume_light)},
        {"volume_map", item(plan.volume_map)},
        {"global_map", item(plan.global_map)},
        {"caustic_map", item(plan.caustic_map)}};
}

}  // namespace fogmap
