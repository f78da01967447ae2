#pragma once
// A scene for a VDB cache alone (`fogmap render cache.vdb`): the grids recognised by their
// conventional names (Houdini and Blender), a camera that frames the density's active bounds,
// sun and sky, a ground under the volume, a density scale and emission from the grids found.
// Y is up (Houdini's and OpenVDB's convention). A starting point that the user edits: `render
// --write-scene` writes it as a scene file (docs/scene-format.md, A VDB alone).

#include "media/density_grid.h"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace fogmap {

/// A scene file's path that is a VDB cache rather than JSON (by its extension).
bool is_vdb_path(const std::string& path);

/// What vdb_scene_json does with each grid of a file, in file order ("density (the medium)",
/// "emission (blackbody, in kelvin)", "colour (...)", "not used: velocity motion blur ...").
std::vector<std::string> grid_uses(const std::vector<GridInfo>& grids);

/// The grids of frame `frame` of the VDB file `file` that the made scene does not use (a
/// velocity grid, say), each as a warning's text: "FILE: grid 'vel': not used: ...".
std::vector<std::string> unused_grid_warnings(const std::string& file, int frame);

/// The scene, as a scene file's JSON, for the VDB file `file` (which may hold a frame pattern:
/// `frame` is then the frame whose file is inspected, and the medium keeps the pattern). Its
/// medium's file is `file`'s name, relative to `file`'s folder as a scene file's would be.
/// Throws InputError{file, "", reason} when the file has no float grid to render.
nlohmann::json vdb_scene_json(const std::string& file, int frame);

}  // namespace fogmap
