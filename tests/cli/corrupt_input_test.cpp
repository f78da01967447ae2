// Hostile input through the fogmap command line: truncated and bit-flipped VDB files, VDBs crafted
// to overflow OpenVDB 10.0's blosc reader or to make it allocate 4 GB,
// truncated JSON, JSON with huge numbers or deep nesting, a PLY whose header claims 1e12
// vertices. Each must end with exit code 2, exactly one message line "fogmap: error: <file>: ...",
// no new file in the output folder and an existing output left untouched. The corrupted files
// are made by the test (from ../shared/volumes or with OpenVDB) in a temp folder (never
// committed).

#include "test_support.h"

#include <gtest/gtest.h>
#include <openvdb/openvdb.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <sstream>
#include <string>

namespace fogmap {
namespace {

namespace fs = std::filesystem;

using test::RunResult;
using test::slurp;
using test::spit;

class CorruptInput : public ::testing::Test {
protected:
    void SetUp() override {
        fs::create_directories(dir_ / "out");
        spit(dir_ / "out" / "old.exr", "an older render");
    }

    /// Runs fogmap with `args` through the shell, after `shell_prefix` (e.g. "ulimit -v N; ").
    RunResult run(const std::string& args, const std::string& shell_prefix = "") {
        return test::run_fogmap(args, dir_, shell_prefix);
    }

    /// Renders `scene` to out/old.exr (an existing file) and expects the rejection contract.
    void expect_rejected(const fs::path& scene, const std::string& names) {
        const RunResult r =
            run("render -q " + scene.string() + " -o " + (dir_ / "out" / "old.exr").string());
        expect_clear_error(r, names);
    }

    void expect_clear_error(const RunResult& r, const std::string& names) {
        EXPECT_FALSE(r.signaled) << "crashed: " << r.err;
        EXPECT_EQ(r.code, 2) << r.err;
        EXPECT_EQ(r.err.rfind("fogmap: error: ", 0), 0u) << r.err;
        EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one message: " << r.err;
        EXPECT_NE(r.err.find(names), std::string::npos) << "names " << names << ": " << r.err;
        EXPECT_TRUE(slurp(dir_ / "out" / "old.exr") == "an older render") << "old output kept";
        for (const char c : r.err)
            EXPECT_TRUE(c == '\n' || (static_cast<unsigned char>(c) >= 0x20 && c != 0x7f))
                << "printable message: " << r.err;
        std::set<std::string> files;
        for (const auto& e : fs::directory_iterator(dir_ / "out"))
            files.insert(e.path().filename().string());
        EXPECT_EQ(files, std::set<std::string>{"old.exr"}) << "nothing new is written";
    }

    /// A small scene whose top-level object gets `extra` (a leading comma included). A key of
    /// `extra` replaces the base's (a key given twice is an error of its own).
    fs::path scene(const std::string& extra, const std::string& name = "s.json") {
        const std::pair<const char*, const char*> base[] = {
            {"camera",
             R"({"position": [0, 1, 4], "look_at": [0, 0.5, 0], "width": 8, "height": 6})"},
            {"lights", R"([{"type": "sun", "direction": [0.3, -1, 0.2], "irradiance": 3}])"},
            {"materials", R"({"ground": {"type": "diffuse", "albedo": 0.5}})"},
            {"photons", R"({"global": 100, "caustic": 0, "volume": 100})"},
            {"shapes", R"([{"type": "quad", "corner": [-5, 0, -5], "edge_u": [0, 0, 10],
              "edge_v": [10, 0, 0], "material": "ground"}])"}};
        const std::set<std::string> replaced = top_level_keys(extra);
        std::string text;
        for (const auto& [key, value] : base)
            if (!replaced.count(key))
                text += std::string(text.empty() ? "{\n  " : ",\n  ") + "\"" + key + "\": " + value;
        const fs::path p = dir_ / name;
        spit(p, text + extra + "\n}\n");
        return p;
    }

    /// The keys at nesting depth 0 of a JSON fragment such as `, "a": {"b": 1}, "c": 2`.
    static std::set<std::string> top_level_keys(const std::string& fragment) {
        std::set<std::string> keys;
        int depth = 0;
        for (size_t i = 0; i < fragment.size(); ++i) {
            const char c = fragment[i];
            if (c == '{' || c == '[') ++depth;
            if (c == '}' || c == ']') --depth;
            if (c != '"') continue;
            const size_t end = fragment.find('"', i + 1);
            if (end == std::string::npos) break;
            const size_t after = fragment.find_first_not_of(" \n", end + 1);
            if (depth == 0 && after != std::string::npos && fragment[after] == ':')
                keys.insert(fragment.substr(i + 1, end - i - 1));
            i = end;
        }
        return keys;
    }

    fs::path vdb_scene(const fs::path& vdb) {
        return scene(R"(, "media": [{"type": "vdb", "file": ")" + vdb.string() + R"("}])");
    }

    /// The smallest shared volume, or "" (the test skips) when ../shared/volumes is absent.
    static std::string shared_vdb() {
        const fs::path p = fs::path(FOGMAP_SHARED_VOLUMES) / "usd_densityAndHeat.vdb";
        return fs::exists(p) ? slurp(p) : std::string();
    }

    test::TempDir tmp_{"fogmap_corrupt"};
    const fs::path dir_ = tmp_.path();
};

TEST_F(CorruptInput, TruncatedVdbNamesTheFile) {
    const std::string bytes = shared_vdb();
    if (bytes.empty()) return test::missing_shared_volume(FOGMAP_SHARED_VOLUMES);
    // Cut inside the magic number, inside the header, inside the first grid's descriptor and
    // in the middle of the density grid's data.
    for (const size_t keep : {size_t(0), size_t(7), size_t(40), size_t(200), bytes.size() / 2}) {
        SCOPED_TRACE("kept " + std::to_string(keep) + " bytes");
        const fs::path vdb = dir_ / "cut.vdb";
        spit(vdb, bytes.substr(0, keep));
        expect_rejected(vdb_scene(vdb), "cut.vdb");
        expect_clear_error(run("info " + vdb.string()), "cut.vdb");
    }
    // Cut in the last grid ('heat'): `info` reads every grid and must fail; a render reads
    // only 'density' (OpenVDB seeks to it), so it may legitimately succeed.
    const fs::path vdb = dir_ / "cut.vdb";
    spit(vdb, bytes.substr(0, bytes.size() * 99 / 100));
    expect_clear_error(run("info " + vdb.string()), "cut.vdb");
}

TEST_F(CorruptInput, BitFlippedVdbHeaderNamesTheFile) {
    const std::string bytes = shared_vdb();
    if (bytes.empty()) return test::missing_shared_volume(FOGMAP_SHARED_VOLUMES);
    // The magic number and the file format version's low byte: each flip must be detected.
    // (Higher version bytes and the library version read as a newer file: OpenVDB reads on.)
    for (const size_t at : {size_t(0), size_t(3), size_t(8)}) {
        SCOPED_TRACE("flipped byte " + std::to_string(at));
        std::string flipped = bytes;
        flipped[at] = static_cast<char>(flipped[at] ^ 0x5a);
        const fs::path vdb = dir_ / "flip.vdb";
        spit(vdb, flipped);
        expect_rejected(vdb_scene(vdb), "flip.vdb");
    }
}

// Flips in the body of the file are not all detectable (a value may change and stay a valid
// float): the contract there is "no crash": exit 0 with a finite render, or exit 2 naming the
// file with nothing written.
TEST_F(CorruptInput, BitFlippedVdbBodyNeverCrashes) {
    const std::string bytes = shared_vdb();
    if (bytes.empty()) return test::missing_shared_volume(FOGMAP_SHARED_VOLUMES);
    for (int n = 1; n <= 6; ++n) {
        const size_t at = bytes.size() * n / 7;
        SCOPED_TRACE("flipped byte " + std::to_string(at));
        std::string flipped = bytes;
        flipped[at] = static_cast<char>(flipped[at] ^ 0xff);
        const fs::path vdb = dir_ / "flip.vdb";
        spit(vdb, flipped);
        const fs::path out = dir_ / "body.exr";
        const RunResult r = run("render -q " + vdb_scene(vdb).string() + " -o " + out.string() +
                                " --set render.spp=1");
        EXPECT_FALSE(r.signaled) << r.err;
        EXPECT_TRUE(r.code == 0 || r.code == 2) << r.code << ": " << r.err;
        if (r.code == 2) {
            EXPECT_NE(r.err.find("flip.vdb"), std::string::npos) << r.err;
            EXPECT_FALSE(fs::exists(out));
        }
        fs::remove(out);
        fs::remove(dir_ / "body.png");
    }
}

/// A 32^3 float grid of random values (64 all-active leaves) written with blosc, whose first leaf
/// chunk's 8-byte size field is patched to claim a 128 KB uncompressed chunk (a negative size).
/// OpenVDB 10.0's io::bloscFromStream reads that many bytes into the 2 KB leaf buffer before it
/// checks the size: a heap-buffer-overflow ("malloc(): corrupted top size", SIGABRT) unless
/// fogmap reads the file in a child process first (media/vdb_probe.h).
void write_blosc_overflow_vdb(const fs::path& p) {
    openvdb::initialize();
    openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(0.0f);
    grid->setName("density");
    auto acc = grid->getAccessor();
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (int x = 0; x < 32; ++x)
        for (int y = 0; y < 32; ++y)
            for (int z = 0; z < 32; ++z) acc.setValue(openvdb::Coord(x, y, z), u(rng));
    openvdb::io::File file(p.string());
    file.setCompression(openvdb::io::COMPRESS_BLOSC | openvdb::io::COMPRESS_ACTIVE_MASK);
    file.write({grid});
    file.close();
    // A leaf's buffer: value mask (64 bytes 0xff: all active), metadata byte 0 (no inactive
    // values to store), int64 chunk size, blosc chunk (format version byte 2).
    std::string bytes = slurp(p);
    const std::string leaf_head = std::string(64, '\xff') + '\0';
    const size_t at = bytes.find(leaf_head) + leaf_head.size();
    ASSERT_LT(at + 9, bytes.size()) << "no all-active leaf found";
    int64_t size = 0;
    std::memcpy(&size, &bytes[at], 8);
    ASSERT_TRUE(size > 0 && size <= 2048 + 16) << "chunk size " << size;
    ASSERT_EQ(bytes[at + 8], '\x02') << "blosc format version";
    const int64_t claimed = -2048 * 64;
    std::memcpy(&bytes[at], &claimed, 8);
    spit(p, bytes);
}

TEST_F(CorruptInput, VdbChunkSizeOverflowIsRejected) {
    const fs::path vdb = dir_ / "overflow.vdb";
    ASSERT_NO_FATAL_FAILURE(write_blosc_overflow_vdb(vdb));
    const RunResult r = run("info " + vdb.string());
    expect_clear_error(r, "overflow.vdb");
    EXPECT_NE(r.err.find("VDB file"), std::string::npos) << r.err;
    expect_rejected(vdb_scene(vdb), "overflow.vdb");
}

TEST_F(CorruptInput, VdbGridNameOfFourGigabytesIsRejected) {
#ifdef __SANITIZE_ADDRESS__
    GTEST_SKIP() << "the probe's address-space limit (and ulimit -v) cannot apply under ASan";
#endif
    const std::string bytes = shared_vdb();
    if (bytes.empty()) return test::missing_shared_volume(FOGMAP_SHARED_VOLUMES);
    // The first grid descriptor's name length (uint32 before "density") set to ~4 GB: OpenVDB
    // allocates and reads on (with no memory limit a reader grew to 24 GB until killed). The
    // probe's child fails at its own limit; `ulimit -v` (KB) only keeps a regression from taking
    // the machine's memory (fogmap then fails with a bare "std::bad_alloc").
    std::string patched = bytes;
    const size_t at = patched.find(std::string("\x07\0\0\0density", 11));
    ASSERT_NE(at, std::string::npos);
    const uint32_t length = 0xfffffe00u;
    std::memcpy(&patched[at], &length, 4);
    const fs::path vdb = dir_ / "name.vdb";
    spit(vdb, patched);
    const RunResult r = run("info " + vdb.string(), "ulimit -v 4194304; ");
    expect_clear_error(r, "name.vdb");
    EXPECT_NE(r.err.find("memory"), std::string::npos) << r.err;
}

TEST_F(CorruptInput, VdbProbeIsHiddenFromHelp) {
    const RunResult r = run("--help");
    EXPECT_EQ(r.code, 0);
    EXPECT_NE(r.out.find("info"), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find("__probe-vdb"), std::string::npos) << r.out;
}

TEST_F(CorruptInput, TruncatedJsonGivesLineAndColumn) {
    const std::string text = slurp(scene(""));
    for (const size_t keep : {size_t(0), size_t(1), text.size() / 3, text.size() - 3}) {
        SCOPED_TRACE("kept " + std::to_string(keep) + " bytes");
        const fs::path p = dir_ / "cut.json";
        spit(p, text.substr(0, keep));
        expect_rejected(p, "cut.json");
        const RunResult r = run("render -q " + p.string());
        EXPECT_NE(r.err.find("line"), std::string::npos) << r.err;
    }
}

TEST_F(CorruptInput, HugeNumbersAreRejectedByField) {
    const std::pair<std::string, std::string> cases[] = {
        {R"(, "render": {"spp": 1e400})", "1e400"},  // a JSON syntax error: no field yet
        {R"(, "render": {"spp": 99999999999999999999999})", "/render/spp"},
        {R"(, "render": {"max_depth": -99999999999999999999})", "/render/max_depth"},
        {R"(, "photons": {"volume": 18446744073709551615})", "/photons/volume"},
        {R"(, "media": [{"type": "homogeneous", "sigma_s": 1e39,
             "bounds": {"min": [-1, 0, -1], "max": [1, 1, 1]}}])",
         "/media/0/sigma_s"},
        {R"(, "media": [{"type": "homogeneous", "sigma_s": 1e30, "density_scale": 1e30,
             "bounds": {"min": [-1, 0, -1], "max": [1, 1, 1]}}])",
         "/media/0/density_scale"},
        {R"(, "camera": {"position": [0, 1, 4], "look_at": [0, 0.5, 0], "width": 8,
             "height": 6, "fov_deg": 1e-400})",
         "/camera/fov_deg"},
    };
    for (const auto& [extra, field] : cases) {
        SCOPED_TRACE(extra);
        expect_rejected(scene(extra), field);
    }
}

TEST_F(CorruptInput, DeepNestingIsRejected) {
    for (const int depth : {1000, 100000}) {
        SCOPED_TRACE("depth " + std::to_string(depth));
        const std::string nested = std::string(depth, '[') + std::string(depth, ']');
        expect_rejected(scene(R"(, "render": {"spp": )" + nested + "}"), "/render/spp");
        // Unbalanced: a syntax error at the end of the file.
        const fs::path p = dir_ / "open.json";
        spit(p, "{\"render\": " + std::string(depth, '['));
        expect_rejected(p, "open.json");
    }
}

TEST_F(CorruptInput, PlyClaimingATrillionVerticesIsRejected) {
    const fs::path ply = dir_ / "huge.ply";
    spit(ply,
         "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\n"
         "property float x\nproperty float y\nproperty float z\nelement face 1\n"
         "property list uchar int vertex_indices\nend_header\n" +
             std::string(36, '\0'));
    const fs::path p = scene(
        R"(, "shapes": [{"type": "mesh", "file": "huge.ply", "material": "ground"}])", "mesh.json");
    expect_rejected(p, "huge.ply");
    // The same in ASCII.
    spit(ply,
         "ply\nformat ascii 1.0\nelement vertex 1000000000000\nproperty float x\n"
         "property float y\nproperty float z\nelement face 1\n"
         "property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    expect_rejected(p, "huge.ply");
}

}  // namespace
}  // namespace fogmap
