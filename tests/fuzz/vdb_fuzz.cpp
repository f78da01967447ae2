// libFuzzer target: VDB files. The input is written to a file and read by inspect_vdb (`fogmap
// info`) and DensityGrid::load (grid "density", as a scene's medium). Bad input must end in
// InputError; a grid that loads must hold only finite, non-negative densities (the load-time
// sanitising rule) with majorants bounding them.

#include "core/error.h"
#include "media/density_grid.h"

#include <unistd.h>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>

namespace {

const std::string& scratch_path() {
    static const std::string path = "/tmp/fogmap_fuzz_vdb_" + std::to_string(::getpid()) + ".vdb";
    return path;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    {
        std::ofstream out(scratch_path(), std::ios::binary | std::ios::trunc);
        out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
    }
    try {
        (void)fogmap::inspect_vdb(scratch_path());
    } catch (const fogmap::InputError&) {
    }
    try {
        const auto grid = fogmap::DensityGrid::load(scratch_path(), "density", "/media/0");
        const float max_density = grid->max_density();
        if (!std::isfinite(max_density) || max_density < 0.0f) std::abort();
        for (const float m : grid->majorants().max_density)
            if (!(m >= 0.0f && m <= max_density)) std::abort();
        if (!grid->empty()) {
            fogmap::DensityGrid::Sampler sampler(*grid);
            const fogmap::Box3& b = grid->index_bounds();
            for (int i = 0; i <= 8; ++i) {
                const fogmap::Vec3 p = b.lo + (b.hi - b.lo) * (static_cast<float>(i) / 8.0f);
                const float d = sampler.density(p);
                if (!std::isfinite(d) || d < 0.0f || d > max_density) std::abort();
            }
        }
    } catch (const fogmap::InputError&) {
    }
    return 0;
}
