// Reader of corpus/probe_values files (see probe_values.h).
#include "tests/jit/probe_values.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace hfrt::probe {

namespace {

bool parse_double(const std::string& text, double* out) {
  if (text.empty()) return false;
  char* end = nullptr;
  *out = std::strtod(text.c_str(), &end);
  return end == text.c_str() + text.size();
}

// "KEY=value" -> value when the key matches.
bool keyed(const std::string& token, const std::string& key, std::string* value) {
  if (token.compare(0, key.size() + 1, key + "=") != 0) return false;
  *value = token.substr(key.size() + 1);
  return true;
}

}  // namespace

bool read_probe_values(const std::string& path, ProbeValues* out, std::string* error) {
  std::ifstream in(path);
  if (!in) {
    *error = "cannot open " + path;
    return false;
  }
  *out = ProbeValues{};
  bool have_header = false;
  std::string line;
  int line_no = 0;
  auto fail = [&](const std::string& what) {
    *error = path + ":" + std::to_string(line_no) + ": " + what;
    return false;
  };
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    if (line[0] == '#') {
      const std::string tag = "# model: ";
      if (line.compare(0, tag.size(), tag) == 0) {
        std::string model = line.substr(tag.size());
        model = model.substr(0, model.find_first_of(" \t"));
        out->model = std::filesystem::path(model).filename().string();
      }
      continue;
    }
    std::istringstream words(line);
    std::vector<std::string> tok;
    for (std::string w; words >> w;) tok.push_back(w);
    if (!have_header) {
      if (tok.empty() || tok[0] != "OK") return fail("expected the OK header line");
      for (size_t i = 1; i < tok.size(); ++i) {
        std::string v;
        if (keyed(tok[i], "objects", &v))
          out->objects = std::atoi(v.c_str());
        else if (keyed(tok[i], "selected", &v))
          out->selected = v;
        else if (keyed(tok[i], "X", &v))
          out->x_size = std::atoi(v.c_str());
        else if (keyed(tok[i], "A", &v))
          out->a_size = std::atoi(v.c_str());
        else if (keyed(tok[i], "S", &v))
          out->s_size = std::atoi(v.c_str());
      }
      have_header = true;
      continue;
    }
    if (tok.size() < 4) return fail("expected x y z and a value");
    ProbePoint p;
    for (int k = 0; k < 3; ++k) {
      if (!parse_double(tok[k], &p.x[k])) return fail("bad coordinate '" + tok[k] + "'");
    }
    if (tok[3] == "RUNTIME_ERROR") {
      p.runtime_error = true;
      p.f = std::nan("");
      std::string msg;
      for (size_t i = 4; i < tok.size(); ++i) msg += (i > 4 ? " " : "") + tok[i];
      p.error_message = msg;
    } else {
      if (!parse_double(tok[3], &p.f)) return fail("bad value '" + tok[3] + "'");
      for (size_t i = 4; i < tok.size(); ++i) {
        std::string key = "s" + std::to_string(i - 3), v;
        double d;
        if (!keyed(tok[i], key, &v) || !parse_double(v, &d))
          return fail("bad attribute '" + tok[i] + "'");
        p.s.push_back(d);
      }
    }
    out->points.push_back(std::move(p));
  }
  if (!have_header) {
    line_no = 0;
    return fail("no OK header line");
  }
  return true;
}

std::string probe_model_path(const std::string& corpus_dir, const ProbeValues& values) {
  return corpus_dir + "/probes/" + values.model;
}

std::vector<std::string> list_probe_value_files(const std::string& corpus_dir) {
  std::vector<std::string> files;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(corpus_dir + "/probe_values", ec)) {
    if (e.path().extension() == ".txt") files.push_back(e.path().string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

bool values_agree(double want, double got, double rel) {
  if (std::isnan(want) || std::isnan(got)) return std::isnan(want) && std::isnan(got);
  if (std::isinf(want) || std::isinf(got)) return want == got;
  return std::fabs(got - want) <= rel * std::max(1.0, std::fabs(want));
}

}  // namespace hfrt::probe
