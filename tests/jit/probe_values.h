#pragma once
// Reader of the corpus reference values (corpus/probe_values/*.txt, format in
// corpus/README.md), shared by the interpreter conformance test and the stdlib tests.
//
//   # comment lines (one of them "# model: <dir>/<name>.hf ...")
//   OK objects=N selected=NAME X=3 A=1 S=1
//   x y z f s1=v1 [s2=v2 ...]
//   x y z RUNTIME_ERROR message

#include <string>
#include <vector>

namespace hfrt::probe {

/// One evaluated point of the 9x9x9 grid.
struct ProbePoint {
  double x[3] = {0, 0, 0};
  bool runtime_error = false;
  std::string error_message;  ///< the original's message when runtime_error
  double f = 0;
  std::vector<double> s;  ///< s1.. as printed
};

struct ProbeValues {
  std::string model;  ///< file name of the probe model, e.g. "math_builtins.hf"
  int objects = 0;
  std::string selected;  ///< the object that was evaluated
  int x_size = 0, a_size = 0, s_size = 0;
  std::vector<ProbePoint> points;
};

/// Reads one reference file. Returns false (with a message in *error) when the file is
/// missing or malformed.
bool read_probe_values(const std::string& path, ProbeValues* out, std::string* error);

/// The probe model the values belong to: <corpus_dir>/probes/<model>.
std::string probe_model_path(const std::string& corpus_dir, const ProbeValues& values);

/// All reference files of <corpus_dir>/probe_values, sorted by name.
std::vector<std::string> list_probe_value_files(const std::string& corpus_dir);

/// The corpus' agreement rule: |got - want| <= rel * max(1, |want|); NaN only matches NaN.
bool values_agree(double want, double got, double rel = 1e-9);

}  // namespace hfrt::probe
