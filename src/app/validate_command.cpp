// placeholder: `fogmap validate` is being written.
#include "app/commands.h"

#include <CLI/CLI.hpp>

namespace fogmap {

Subcommand add_validate_command(CLI::App& app) {
    CLI::App* sub = app.add_subcommand("validate", "(not yet available)");
    return {sub, [] { return 1; }};
}

}  // namespace fogmap
