// libFuzzer target: scene files. The input is written to a file and read by load_scene_desc
// (JSON parse → SceneDesc with unknown-key and type checks → validate), the path `fogmap render`
// takes. Bad input must end in InputError; anything else (another exception, a crash, a sanitizer
// report, a hang) is a finding. A scene that passes is written back with to_json and must read
// back equal (round trip), which exercises the writer on every accepted value.

#include "core/error.h"
#include "scene/scene_desc_json.h"

#include <unistd.h>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>

namespace {

const std::string& scratch_path() {
    static const std::string path =
        "/tmp/fogmap_fuzz_scene_" + std::to_string(::getpid()) + ".json";
    return path;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    {
        std::ofstream out(scratch_path(), std::ios::binary | std::ios::trunc);
        out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
    }
    try {
        const fogmap::SceneDesc desc = fogmap::load_scene_desc(scratch_path());
        const nlohmann::json again = fogmap::to_json(desc);
        const fogmap::SceneDesc back = fogmap::scene_desc_from_json(again, scratch_path());
        if (fogmap::to_json(back) != again) std::abort();  // the round trip lost a value
    } catch (const fogmap::InputError&) {
    }
    return 0;
}
