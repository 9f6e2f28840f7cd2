// The smallest useful embedding of hfrt: compile a HyperFun model from a string, evaluate it
// at a point and along a batch, and show a run-time error's message.
//
//   hfrt_embed_example            prints the values and exits 0 when all checks hold

#include <cmath>
#include <cstdio>
#include <vector>

#include "hfrt/model.h"

int main() {
  const char* source = R"(
-- A unit sphere with a hole drilled along z, and a colour attribute.
my_model(x[3], a[1], s[1])
{
  r = sqrt(x[1]^2 + x[2]^2 + x[3]^2);
  s[1] = r;
  my_model = (1 - r) & -(0.25 - sqrt(x[1]^2 + x[2]^2)) / a[1];
}
)";
  hfrt::ModelOptions options;  // JIT backend, f64 compiled eagerly
  hfrt::CompileResult compiled = hfrt::Model::compile(source, options, "embed.hf");
  if (!compiled.ok()) {
    std::fprintf(stderr, "%s%s\n", compiled.rendered.c_str(), compiled.error.c_str());
    return 1;
  }
  hfrt::Model& model = *compiled.model;
  model.set_params({1.0});
  std::printf("object %s: x[%d], a[%d], s[%d]\n", model.object_name().c_str(), model.num_inputs(),
              model.num_params(), model.num_attributes());

  // One point.
  hfrt::PointValue v = model.eval({0.5, 0.0, 0.0});
  std::printf("F(0.5, 0, 0) = %.17g, s1 = %.17g\n", v.f, v.s.empty() ? 0.0 : v.s[0]);

  // A batch along the x axis (structure of arrays: xs[k*n + i]), in single precision.
  const int n = 9;
  std::vector<float> xs(3 * n, 0.0f), f(n);
  for (int i = 0; i < n; ++i) xs[i] = -1.2f + 0.3f * i;
  model.eval_batch(n, xs.data(), f.data());
  for (int i = 0; i < n; ++i) std::printf("F(%g, 0, 0) = %g\n", xs[i], f[i]);

  // a[1] = 0 divides by zero: the value is NaN and the error says where.
  model.set_params({0.0});
  hfrt::PointValue e = model.eval({0.5, 0.0, 0.0});
  std::printf("with a[1] = 0: %s (line %d pos %d)\n", e.error.c_str(), e.error_line, e.error_col);

  // At (0.5, 0, 0): f1 = 1 - 0.5, f2 = 0.5 - 0.25, and f1 & f2 = f1 + f2 - sqrt(f1^2 + f2^2).
  const double f1 = 0.5, f2 = 0.25, want = f1 + f2 - std::sqrt(f1 * f1 + f2 * f2);
  bool ok = std::fabs(v.f - want) < 1e-12 && std::isnan(e.f) && !e.ok() && f[6] > 0 && f[4] < 0;
  std::printf("%s\n", ok ? "embed example: OK" : "embed example: UNEXPECTED VALUES");
  return ok ? 0 : 1;
}
