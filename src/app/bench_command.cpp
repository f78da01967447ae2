// placeholder: `fogmap bench` is being written.
#include "app/commands.h"

#include <CLI/CLI.hpp>

namespace fogmap {

Subcommand add_bench_command(CLI::App& app) {
    CLI::App* sub = app.add_subcommand("bench", "(not yet available)");
    return {sub, [] { return 1; }};
}

}  // namespace fogmap
