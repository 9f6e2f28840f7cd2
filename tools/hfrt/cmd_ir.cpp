// Placeholder: the `hfrt ir` subcommand is implemented by its issue.
#include "tools/hfrt/commands.h"

namespace hfrt::tools {
CommandRunner register_ir(CLI::App&) { return [] { return 2; }; }
}  // namespace hfrt::tools
