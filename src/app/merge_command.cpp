// `fogmap merge PARTS... -o OUT.exr`: the image of a run split by `fogmap render --part I/N` over
// processes that never talk (a farm without MPI; docs/distributed.md). Checks that the files are
// the N parts of one run, each once — the same settings, seed and input files — before reading
// any film, then adds their sums up in part order as rank 0 of `mpirun -np N` does (the EXR is the
// same bytes as that run's and one process's), estimates the error, writes the EXR and PNG
// (both complete before either replaces an older one) and prints the report.

#include "app/commands.h"
#include "core/error.h"
#include "core/image.h"
#include "core/output_files.h"
#include "core/timer.h"
#include "render/part_file.h"
#include "render/pipeline.h"
#include "render/report.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace fogmap {

namespace {

namespace fs = std::filesystem;

struct MergeArgs {
    std::vector<std::string> parts;
    std::string output, png, reference;
    float exposure = 0.0f;
    bool json = false;
};

/// Fails naming `path` unless its run is `first`'s (read from `first_path`).
void expect_same_run(const std::string& path, const PartRun& run, const std::string& first_path,
                     const PartRun& first) {
    const std::string of_first =
        "; " + first_path + " (part " + std::to_string(first.index) + ") is of ";
    if (run.count != first.count)
        throw InputError(path, "parts",
                         "a part of " + std::to_string(run.count) + of_first +
                             std::to_string(first.count) + ": the parts of one image share N");
    if (run.seed != first.seed)
        throw InputError(path, "seed",
                         std::to_string(run.seed) + of_first + "seed " +
                             std::to_string(first.seed) + ": the parts of one image share a seed");
    if (run.settings != first.settings)
        throw InputError(path, "settings",
                         "rendered from another scene or other settings than " + first_path +
                             " (the scene after --set, resolved; only render.threads may differ)");
    if (run.inputs != first.inputs)
        throw InputError(path, "inputs",
                         "rendered from input files (volumes, meshes) whose contents differ from "
                         "those " +
                             first_path + " read");
}

/// The part files in part order, checked to be the parts of one run, each once.
std::vector<std::pair<std::string, PartRun>> check_parts(const std::vector<std::string>& paths) {
    std::vector<std::pair<std::string, PartRun>> runs;
    for (const std::string& path : paths) runs.emplace_back(path, read_part_run(path));
    const std::string first_path = runs.front().first;  // as given: the others are checked by it
    const int count = runs.front().second.count;
    for (const auto& [path, run] : runs)
        expect_same_run(path, run, first_path, runs.front().second);
    std::stable_sort(runs.begin(), runs.end(),
                     [](const auto& a, const auto& b) { return a.second.index < b.second.index; });
    for (size_t k = 1; k < runs.size(); ++k)
        if (runs[k].second.index == runs[k - 1].second.index)
            throw InputError(runs[k].first, "part",
                             "part " + std::to_string(runs[k].second.index) + " of " +
                                 std::to_string(count) + ", as " + runs[k - 1].first +
                                 " is: expected each part once");
    for (int i = 1; i <= count; ++i)
        if (size_t(i) > runs.size() || runs[size_t(i) - 1].second.index != i)
            throw InputError(first_path, "parts",
                             "part " + std::to_string(i) + " of " + std::to_string(count) +
                                 " is missing (" + std::to_string(runs.size()) +
                                 " part files given); expected one file of each part, 1 to " +
                                 std::to_string(count));
    return runs;
}

int run_merge(const MergeArgs& a) {
    const Timer timer;
    if (!fs::path(a.output).has_extension() || fs::path(a.output).extension() != ".exr")
        throw InputError("", "-o",
                         "'" + a.output + "' does not end in .exr; expected an .exr path");
    const std::string png =
        a.png.empty() ? fs::path(a.output).replace_extension(".png").string() : a.png;
    if (fs::path(png).extension() != ".png")
        throw InputError("", "--png", "'" + png + "' does not end in .png; expected a .png path");
    if (!std::isfinite(a.exposure))
        throw InputError("", "--exposure", "expected a finite number of stops");
    std::vector<std::pair<std::string, std::string>> inputs = {{a.reference, "reference image"}};
    for (const std::string& p : a.parts) inputs.emplace_back(p, "part file");
    for (const auto& [path, option] : {std::pair{a.output, "-o"}, std::pair{png, "--png"}}) {
        check_not_an_input(path, option, inputs);
        check_output_path(path, option);
    }
    Image reference;
    if (!a.reference.empty()) {
        reference = read_exr(a.reference);
        check_finite(reference, a.reference);
    }
    const std::vector<std::pair<std::string, PartRun>> runs = check_parts(a.parts);
    const RunSetup& setup = runs.front().second.setup;
    if (!a.reference.empty()) check_reference_size(a.reference, reference, setup.run.camera);
    check_run_memory(setup, !a.reference.empty());
    PartMerge merge;
    std::optional<PartSums::FilmShape> shape;  // part 1's
    for (const auto& [path, run] : runs) {
        PartFile part = read_part(path);
        expect_same_run(path, part.run, runs.front().first, runs.front().second);
        if (!shape)
            shape = part.sums.shape;
        else if (!(part.sums.shape == *shape))
            throw InputError(path, "film",
                             "its film's layers or batches differ from those of " +
                                 runs.front().first + "; the file is corrupt");
        merge.add(std::move(part.sums));
    }
    PipelineResult result = merge.finish(setup, /*speak=*/true);
    add_phase(&result.report, "merge", timer.seconds());
    write_image(&result, a.output, png, a.exposure, a.reference.empty() ? nullptr : &reference,
                a.reference);
    const Report& report = result.report;
    if (a.json)
        std::cout << report_json(report).dump(2) << "\n";
    else
        std::cout << report_text(report);
    return 0;
}

}  // namespace

Subcommand add_merge_command(CLI::App& app) {
    auto args = std::make_shared<MergeArgs>();
    CLI::App* sub = app.add_subcommand(
        "merge", "the EXR and PNG of a run rendered in parts (render --part I/N), from its parts");
    sub->add_option("parts", args->parts, "the part files, one of each part, in any order")
        ->required();
    sub->add_option("-o,--output", args->output, "output .exr")->required();
    sub->add_option("--png", args->png, "PNG preview path (default beside the EXR)");
    sub->add_option("--exposure", args->exposure, "PNG exposure in stops");
    sub->add_option("--reference", args->reference, "reference .exr: report RMSE, relMSE, bias");
    sub->add_flag("--json", args->json, "print the report as JSON on stdout");
    return {sub, [args](Ranks*) { return run_merge(*args); }};
}

}  // namespace fogmap
