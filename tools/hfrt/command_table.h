#pragma once
// The subcommands of `hfrt`, in the order of the help, with their one-line descriptions. One
// table for two users: each register_*() (commands.h) adds its subcommand from it
// (add_command), and the launcher (main.cpp) prints the top-level help from it without loading
// the commands themselves (tools/hfrt/cli_main.cpp, in the run-time module libhfrt_cli.so).

#include <string_view>

namespace hfrt::tools {

struct CommandInfo {
  std::string_view name;
  std::string_view description;
  bool hidden = false;  ///< a developer's command: not in the help
};

inline constexpr CommandInfo kCommands[] = {
    {"check",
     "Parse and check HyperFun files (.hf) or scene files (.toml); print errors and warnings "
     "with their location"},
    {"ir", "Print the intermediate representation of a HyperFun object"},
    {"eval",
     "Evaluate a model at points read from stdin (one per line: x1 x2 x3 ...), or over boxes "
     "(--interval), or with its gradient (--gradient)"},
    {"render", "ray trace a model to an image (PNG, EXR, TIFF, JPEG)"},
    {"slice", "render a 2-D model or a z slice as an inside/outside image"},
    {"repl",
     "interactive session: define objects, :eval, :render (type :help); with stdin not a "
     "terminal, runs the lines as a script"},
    {"emit", "write a model in another renderer's language (--pov: a POV-Ray isosurface scene)"},
    {"mesh", "polygonise the solid into a watertight triangle mesh (STL, OBJ, PLY, glTF)"},
    {"gpu-cases", "write the device check's cases (scripts/gpu-check.sh)", true},
    {"cache", "the compile cache: `info` (folder, entries, size) or `clear` (remove every entry)"},
};

/// The table's row of `name`, or null.
constexpr const CommandInfo* find_command(std::string_view name) {
  for (const CommandInfo& c : kCommands) {
    if (c.name == name) return &c;
  }
  return nullptr;
}

/// The top-level description and the --no-cache flag's help, shared by both front ends.
inline constexpr const char* kAppDescription =
    "hfrt: a compiler and ray tracer for the HyperFun FRep modelling language";
inline constexpr const char* kNoCacheHelp =
    "compile without the compile cache on disk (also HFRT_NO_CACHE=1; `hfrt cache`)";

}  // namespace hfrt::tools
