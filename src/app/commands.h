#pragma once
// The fogmap subcommands, one function each; main.cpp only parses arguments and maps errors to
// exit codes (InputError → 2). Each returns the process exit code.

#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace CLI {
class App;
class Validator;
}

namespace fogmap {

struct SceneDesc;
struct CameraDesc;
struct Image;
class Ranks;

struct RenderArgs {
    std::string scene;         ///< scene file
    std::string output;        ///< .exr path; "" = out/<scene stem>.exr
    std::string png;           ///< .png path; "" = beside the EXR
    std::string reference;     ///< .exr to compare with; "" = none
    bool progressive = false;  ///< --progressive: the scene's progressive.* must enable it
    std::vector<std::string> overrides;  ///< "key.path=value"
    float exposure = 0.0f;               ///< PNG preview exposure, stops
    bool quiet = false;
    bool json = false;
    std::string frames;   ///< --frames FIRST-LAST[:STEP]; "" = one image (core/frames.h)
    bool resume = false;  ///< skip frames whose EXR and PNG exist; continue from a checkpoint
    double checkpoint_every = 0.0;  ///< progressive: seconds between checkpoints; 0 = none
    std::string write_scene;        ///< --write-scene: write the scene (with --set) here, no render
    bool dry_run = false;           ///< --dry-run: the checks, the plan and the predicted peak
    std::string part;  ///< --part I/N: part I of N to a part file (render/part_file.h); "" = all
    Ranks* ranks = nullptr;         ///< under mpirun: this job's ranks (rank 0 prints and writes)
};

int run_render(const RenderArgs& args);
int run_info(const std::string& vdb_path, bool json);

struct VolumeArgs {
    std::string shape;   ///< "cloud", "plume" or "fireball"
    std::string output;  ///< .vdb path (with a frame pattern when frames is set)
    int resolution = 64;
    float voxel_size = 0.05f;
    uint64_t seed = 1;
    std::string frames;  ///< --frames FIRST-LAST[:STEP]: a time-varying sequence; "" = one grid
    bool velocity = false;  ///< --velocity: plume and fireball also write their "vel" grid
};

int run_volume(const VolumeArgs& args);

/// Checks render and bench make before any work (app/commands.cpp).
/// Caps render.threads at the cores this process may use: returns the warning it printed on
/// stderr ("" when the setting was within them), for the report.
std::string cap_threads(SceneDesc* desc);
struct RunSetup;
/// The memory of one resolved run, estimated up front: images (every film layer twice, the
/// reference and the PNG) and photon maps (at the bytes per photon docs/measurements.md gives),
/// in bytes; `layers`: the film's images per pixel.
struct RunMemory {
    double images = 0.0, maps = 0.0;
    int layers = 0;
};
RunMemory run_memory(const RunSetup& setup, bool with_reference);
/// Throws InputError naming run_memory's estimate in MB when it exceeds core/memory_budget.h's
/// budget.
void check_run_memory(const RunSetup& setup, bool with_reference);
/// Throws InputError{path, "", ...} unless `reference` (read from `path`) is the camera's size.
void check_reference_size(const std::string& path, const Image& reference,
                          const CameraDesc& camera);
struct PipelineResult;
/// Writes `run`'s image to `exr` and `png` (both complete before either replaces an older one,
/// core/output_files.h) with the time it took, and with `reference` (read from reference_path;
/// may be null) its error, in run's report.
void write_image(PipelineResult* run, const std::string& exr, const std::string& png,
                 float exposure, const Image* reference, const std::string& reference_path);
/// Throws InputError{output, option, ...} when the output path names one of the run's inputs.
void check_not_an_input(const std::string& output, const std::string& option,
                        const std::vector<std::pair<std::string, std::string>>& inputs);

/// A subcommand registered by its own file: when `app` was chosen on the command line, main
/// calls `run` and exits with its result (InputError → 2 as everywhere). With `mpi`, main starts
/// MPI under mpirun first and passes the job's ranks (else null).
struct Subcommand {
    CLI::App* app;
    std::function<int(Ranks*)> run;
    bool mpi = false;
};

/// `fogmap validate slab ...` (app/validate_command.cpp).
Subcommand add_validate_command(CLI::App& app);
/// A seed option's check: digits alone (an unsigned option would read "-1" as 2^64 - 1).
CLI::Validator seed_check();
/// `fogmap bench SCENE ...` (app/bench_command.cpp).
Subcommand add_bench_command(CLI::App& app);
/// `fogmap merge PARTS... -o OUT.exr` (app/merge_command.cpp).
Subcommand add_merge_command(CLI::App& app);

/// A digest of a file's size and contents at 16 places: the same for copies of it (ranks and
/// parts on other machines read copies, whose modification times differ).
std::string file_digest(const std::string& path);
/// The paths of every file the scene reads (VDB media, then meshes), resolved.
std::vector<std::string> input_files(const SceneDesc& desc);

}  // namespace fogmap
