// hfrt from C++ through the installed CMake package (find_package(hfrt) -> hfrt::hfrt): the
// public C++ API hfrt/model.h and the render entry point hfrt/render.h.
//
//   echo "1 2 3" | hfrt_eval_cxx MODEL.hf [OBJECT [a1,a2,...]]   F and s[] like `hfrt eval`
//   hfrt_eval_cxx MODEL.hf --render W H OUT.png                    ray trace into RGBA floats

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "hfrt/model.h"
#include "hfrt/render.h"

namespace {

void print_number(double v) {
  if (std::isnan(v)) {
    std::fputs("nan", stdout);
  } else {
    std::printf("%.17g", v);
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s MODEL.hf [OBJECT [a1,...]] [--render W H OUT.png]\n", argv[0]);
    return 2;
  }
  hfrt::ModelOptions options;
  std::vector<double> params;
  int render_at = 0;
  for (int i = 2; i < argc; ++i) {
    if (std::string(argv[i]) == "--render") {
      render_at = i;
      break;
    }
    if (i == 2) options.object = argv[i];
    if (i == 3) {
      std::stringstream ss(argv[i]);
      std::string item;
      while (std::getline(ss, item, ',')) params.push_back(std::strtod(item.c_str(), nullptr));
    }
  }
  hfrt::CompileResult compiled = hfrt::Model::compile_file(argv[1], options);
  if (!compiled.ok()) {
    std::fprintf(stderr, "%s%s\n", compiled.rendered.c_str(), compiled.error.c_str());
    return 1;
  }
  hfrt::Model& model = *compiled.model;
  if (!params.empty()) model.set_params(params);

  if (render_at > 0 && render_at + 3 < argc) {
    hfrt::RenderSettings settings;
    settings.width = std::atoi(argv[render_at + 1]);
    settings.height = std::atoi(argv[render_at + 2]);
    std::vector<float> rgba(4 * size_t(settings.width) * size_t(settings.height));
    hfrt::RenderOutcome r = hfrt::render_model(model, settings, rgba.data(), rgba.size(), argv[1]);
    if (!r.ok()) {
      std::fprintf(stderr, "render failed: %s\n", r.error.c_str());
      return 1;
    }
    std::string err =
        hfrt::write_rgba_image(argv[render_at + 3], settings.width, settings.height, rgba.data());
    if (!err.empty()) {
      std::fprintf(stderr, "%s\n", err.c_str());
      return 2;
    }
    return 0;
  }

  const int k = model.num_inputs(), ns = model.num_attributes();
  std::vector<double> rows;
  std::string line;
  size_t n = 0;
  while (std::getline(std::cin, line)) {
    size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream in(line);
    for (int j = 0; j < k; ++j) {
      double v = 0;
      if (!(in >> v)) v = 0;
      rows.push_back(v);
    }
    ++n;
  }
  std::vector<double> xs(n * k), f(n), s(n * ns);
  for (size_t i = 0; i < n; ++i) {
    for (int j = 0; j < k; ++j) xs[j * n + i] = rows[i * k + j];
  }
  model.eval_batch(int64_t(n), xs.data(), f.data(), ns ? s.data() : nullptr);
  for (size_t i = 0; i < n; ++i) {
    print_number(f[i]);
    for (int j = 0; j < ns; ++j) {
      std::putchar(' ');
      print_number(s[j * n + i]);
    }
    std::putchar('\n');
  }
  return 0;
}
