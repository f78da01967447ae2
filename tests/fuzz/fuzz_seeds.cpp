// Writes the starting corpus of a fuzz target into a folder: truncated and bit-flipped copies of
// ../shared/volumes/*.vdb (kind vdb) or scenes/*.json (kind scene), plus, for vdb, a tiny grid
// fogmap writes itself (with NaN, Inf, negative and denormal voxels) so that whole, valid files
// fit the fuzzer's max_len. Deterministic (fixed xorshift seed per file).
// Usage: fuzz_seeds vdb|scene <source dir> <corpus dir>

#include "media/volume_gen.h"

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

constexpr size_t kMaxSeed = 131072;  // run_fuzz.cmake's -max_len

std::string slurp(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

uint64_t xorshift(uint64_t* s) {
    *s ^= *s << 13;
    *s ^= *s >> 7;
    *s ^= *s << 17;
    return *s;
}

int written = 0;

void put(const fs::path& dir, const std::string& name, const std::string& bytes) {
    std::ofstream(dir / name, std::ios::binary) << bytes;
    ++written;
}

/// Prefixes of `bytes` and copies with 1, 2, 8 and 32 flipped bits (of the whole file when it
/// fits the fuzzer's max_len, else of its first kMaxSeed bytes).
void derive(const fs::path& dir, const std::string& stem, const std::string& bytes,
            const std::vector<size_t>& cuts) {
    for (size_t cut : cuts)
        if (cut < bytes.size()) put(dir, stem + ".cut" + std::to_string(cut), bytes.substr(0, cut));
    const std::string base = bytes.substr(0, kMaxSeed);
    put(dir, stem + ".whole", base);
    uint64_t state = 0x9e3779b97f4a7c15ull ^ bytes.size();
    for (int flips : {1, 2, 8, 32}) {
        for (int copy = 0; copy < 3; ++copy) {
            std::string b = base;
            for (int f = 0; f < flips && !b.empty(); ++f) {
                const uint64_t r = xorshift(&state);
                b[r % b.size()] ^= static_cast<char>(1u << ((r >> 32) % 8));
            }
            put(dir, stem + ".flip" + std::to_string(flips) + "_" + std::to_string(copy), b);
        }
    }
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 4) {
        std::fprintf(stderr, "usage: fuzz_seeds vdb|scene <source dir> <corpus dir>\n");
        return 2;
    }
    const std::string kind = argv[1];
    const fs::path source = argv[2], corpus = argv[3];
    fs::create_directories(corpus);
    if (kind == "vdb") {
        const fs::path shared = source / ".." / "shared" / "volumes";
        if (fs::exists(shared)) {
            for (const auto& e : fs::directory_iterator(shared)) {
                if (e.path().extension() != ".vdb") continue;
                derive(corpus, e.path().filename().string(), slurp(e.path()),
                       {8, 16, 64, 65, 128, 512, 4096, 32768, 131072});
            }
        }
        const fs::path tiny = corpus / "tiny.tmp";
        const float bad[] = {std::numeric_limits<float>::quiet_NaN(),
                             std::numeric_limits<float>::infinity(), -1.0f,
                             std::numeric_limits<float>::denorm_min()};
        fogmap::write_float_grid(
            tiny.string(), "density", 6, 5, 4,
            [&](int i, int j, int k) { return (i + j + k) % 5 == 0 ? bad[(i + k) % 4] : 0.5f; },
            fogmap::Vec3(0.1f, 0.2f, 0.1f), fogmap::Vec3(-0.3f, 0.0f, 0.2f));
        const std::string t = slurp(tiny);
        fs::remove(tiny);
        derive(corpus, "tiny.vdb", t, {8, 64, 100, t.size() / 2, t.size() - 1});
    } else if (kind == "scene") {
        for (const auto& e : fs::directory_iterator(source / "scenes")) {
            if (e.path().extension() != ".json") continue;
            const std::string text = slurp(e.path());
            derive(corpus, e.path().filename().string(), text,
                   {1, text.size() / 4, text.size() / 2, text.size() - 2});
        }
    } else {
        std::fprintf(stderr, "fuzz_seeds: unknown kind '%s'; expected vdb or scene\n", argv[1]);
        return 2;
    }
    std::printf("fuzz_seeds: %d %s seeds in %s\n", written, kind.c_str(), corpus.c_str());
    return written > 0 ? 0 : 1;
}
