#pragma once
// Scene files: JSON ⇄ SceneDesc. Unknown keys are errors that list the known keys; wrong types
// name the JSON pointer and the expected type; "--set a.b=v" overrides edit the JSON before it
// is read, so command-line values pass the same checks. Colours accept a number or [r, g, b].

#include "scene/scene_desc.h"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace fogmap {

/// The scene file `path` as JSON with the overrides applied ("render.spp=64",
/// "lights.0.intensity=[1,2,3]": the value is JSON if it parses as JSON, else a string). A VDB
/// file (scene/vdb_scene.h, is_vdb_path) gives the scene made for it, from frame `frame` of a
/// frame pattern. Throws InputError{path, field, reason}; JSON syntax errors give line and
/// column.
nlohmann::json scene_document(const std::string& path, const std::vector<std::string>& overrides,
                              int frame = 0);

/// scene_document, converted and validated. The file's keys alone: render/run_setup.h resolves
/// what runs. Throws InputError{path, field, reason}.
SceneDesc load_scene_desc(const std::string& path, const std::vector<std::string>& overrides = {},
                          int frame = 0);

/// Applies one "dotted.key=value" override to a JSON document (creating missing object keys).
/// Throws InputError{file, "/dotted/key", reason} if the path goes through a non-object or an
/// array index out of range, or the text has no '='.
void apply_override(nlohmann::json& doc, const std::string& assignment, const std::string& file);

/// JSON document → SceneDesc (no validation). `file` is used in error messages and its folder
/// becomes base_dir.
SceneDesc scene_desc_from_json(const nlohmann::json& doc, const std::string& file);

/// SceneDesc → JSON with every field (keys set by rule only where given);
/// scene_desc_from_json(to_json(d)) reads back d exactly.
nlohmann::json to_json(const SceneDesc& desc);

/// The render settings alone: {integrator, spp, max_depth, seed, threads}.
nlohmann::json to_json(const RenderSettings& render);
/// The settings (every key but the camera, lights, materials, shapes and media), every field
/// written: {render, photons, global, caustic, volume, march, progressive}.
nlohmann::json settings_json(const SceneDesc& desc);

}  // namespace fogmap
