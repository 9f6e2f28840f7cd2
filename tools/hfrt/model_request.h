#pragma once
// The model options every command that compiles a model takes (the file, --object, -a,
// --backend, the limits), and loading it with its diagnostics printed as the command line prints
// them.

#include <optional>
#include <string>
#include <vector>

#include "hfrt/model.h"

namespace CLI {
class App;
}

namespace hfrt::tools {

/// Options common to the commands that compile a model.
struct ModelRequest {
  std::string file;
  std::string object;
  std::string params;  ///< "v1,v2,..." for a[1..]
  std::string backend = "jit";
  std::string time;    ///< --time: x[4] of the model ("" : 0)
  ModelLimits limits;  ///< --max-loop-iterations, --max-array-size, ... (add_limit_options)
};

/// Registers the options of the limits on hostile input (docs/limits.md) on a command that
/// compiles models: --max-loop-iterations N, --max-array-size N, --max-slots N,
/// --max-model-size N, --max-source-bytes N, --max-mesh-bytes N, --max-mesh-triangles N,
/// --max-exact-curves N.
void add_limit_options(CLI::App& app, ModelLimits* limits);

/// A compiled model ready for rendering, with its compile time.
struct LoadedModel {
  std::optional<Model> model;
  double compile_ms = 0;
};

/// Parses a --time value (a finite number); false when malformed, with the message (without a
/// prefix) in `*err`.
bool parse_time(const std::string& text, double* out, std::string* err);

/// Compiles the model and applies --object, -a and --time (with a note on stderr when the
/// object has fewer than four coordinates, so that time cannot reach it). On failure prints the
/// reason (diagnostics for source errors) and returns nullopt with `*exit_code` = 1 (compile
/// errors) or 2 (usage or environment).
std::optional<LoadedModel> load_model(const ModelRequest& request, bool eager_f32, int* exit_code);

/// Parses "v1,v2,..." (exactly `count` numbers when count > 0). False when malformed.
bool parse_doubles(const std::string& text, std::vector<double>* out, size_t count = 0);
bool parse_floats(const std::string& text, std::vector<float>* out, size_t count = 0);

}  // namespace hfrt::tools
