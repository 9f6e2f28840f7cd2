// `hfrt eval MODEL.hf [--object NAME] [-a v1,v2,...] [--backend jit|interp]
//                     [--precision f64|f32] [--interval | --gradient] [--stats]`
//
// Reads points from stdin, one per line: whitespace-separated coordinates x[1] x[2] ...
// (missing ones are 0, extra ones ignored; blank lines and lines starting with '#' are
// skipped). Prints one line per point: F with 17 significant digits (%.17g), then the s[]
// values, space-separated. A point without a value (a run-time error) prints `nan` and the
// message of the first error with its location, e.g. `nan Division by zero (line 3 pos 14)`.
//
// --interval: each line is a box `x0 x1 y0 y1 z0 z1` (a lo hi pair per coordinate; missing
// pairs are the point 0, a lone last lo is the point lo); prints `lo hi` (17 significant
// digits, `inf`/`-inf` possible) of an enclosure of F over the box, with ` nan` appended when
// the box may contain points without a value. Always f64 (the interval domain has no f32).
//
// --gradient: each line is a point, as without flags; prints `f dfdx dfdy dfdz` (F and its
// exact derivatives by automatic differentiation, in the --precision); a point without a
// value prints `nan nan nan nan` (the columns stay aligned for scripts).
//
// Both backends print the same text: the JIT evaluates the points in blocks of kBlock
// (vectorised), and each point whose F is NaN is evaluated again by the reference
// interpreter, which knows which error happened and where.
//
// Exit codes: 0 = done, 1 = the model has compile errors (diagnostics on stderr),
// 2 = usage or environment error (unreadable file, malformed input, JIT failure).

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include "base/timer.h"
#include "hfrt/model.h"
#include "tools/hfrt/commands.h"
#include "tools/hfrt/model_request.h"

namespace hfrt::tools {
namespace {

constexpr size_t kBlock = 4096;  ///< points per JIT batch call

struct EvalOptions {
  std::string file;
  std::string object;
  std::string params;
  std::string backend = "jit";
  std::string precision = "f64";
  int opt_level = 2;
  bool interval = false;
  bool gradient = false;
  bool stats = false;
  ModelLimits limits;
};

void append_number(std::string& out, double v) {
  if (std::isnan(v)) {
    out += "nan";  // never "-nan"
    return;
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  out += buf;
}

/// Parses "v1,v2,..." into doubles; false on a malformed list.
bool parse_params(std::string text, std::vector<double>* out) {
  if (!text.empty() && text[0] == '=') text.erase(0, 1);  // `-a=1,2` (CLI11 keeps the '=')
  if (text.empty()) return true;
  size_t pos = 0;
  while (pos <= text.size()) {
    size_t comma = text.find(',', pos);
    std::string item =
        text.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
    char* end = nullptr;
    double v = std::strtod(item.c_str(), &end);
    if (item.empty() || *end != '\0') return false;
    out->push_back(v);
    if (comma == std::string::npos) break;
    pos = comma + 1;
  }
  return true;
}

/// Reads stdin points as rows of `dims` numbers (missing ones are 0, extra ones ignored).
/// `given`, when non-null, receives how many numbers each row had. On malformed input,
/// prints the line and returns false.
bool read_points(int dims, std::vector<double>* rows, size_t* count,
                 std::vector<int>* given = nullptr) {
  std::string text((std::istreambuf_iterator<char>(std::cin)), std::istreambuf_iterator<char>());
  size_t line_no = 0, pos = 0;
  *count = 0;
  while (pos < text.size()) {
    size_t eol = text.find('\n', pos);
    if (eol == std::string::npos) eol = text.size();
    std::string line = text.substr(pos, eol - pos);
    pos = eol + 1;
    ++line_no;
    size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::vector<double> p(static_cast<size_t>(dims), 0.0);
    const char* c = line.c_str();
    for (int k = 0;; ++k) {
      while (*c == ' ' || *c == '\t' || *c == '\r') ++c;
      if (!*c) break;
      char* end = nullptr;
      double v = std::strtod(c, &end);
      if (end == c || (*end && *end != ' ' && *end != '\t' && *end != '\r')) {
        std::fprintf(stderr, "hfrt: stdin line %zu: cannot read '%s' as a number\n", line_no,
                     std::string(c, std::strcspn(c, " \t\r")).c_str());
        return false;
      }
      if (k < dims) p[k] = v;
      if (given && k == 0) given->push_back(0);
      if (given) given->back() = k + 1;
      c = end;
    }
    if (given && given->size() == *count) given->push_back(0);
    rows->insert(rows->end(), p.begin(), p.end());
    ++*count;
  }
  return true;
}

/// `--interval`: boxes from stdin, `lo hi [nan]` per box.
int eval_boxes(const Model& model, size_t* count) {
  const int dims = model.num_inputs();
  std::vector<double> rows;
  std::vector<int> given;
  if (!read_points(2 * dims, &rows, count, &given)) return 2;
  const size_t n = *count;
  // Validate and complete every box before printing anything.
  for (size_t i = 0; i < n; ++i) {
    double* b = &rows[i * 2 * dims];
    for (int k = 0; k < dims; ++k) {
      if (2 * k + 1 >= given[i]) b[2 * k + 1] = b[2 * k];  // a lone lo (or nothing): a point
      if (!(b[2 * k] <= b[2 * k + 1])) {
        std::fprintf(stderr,
                     "hfrt: box %zu, coordinate %d: the lower bound %g is above the upper bound %g "
                     "(boxes are x0 x1 y0 y1 z0 z1)\n",
                     i + 1, k + 1, b[2 * k], b[2 * k + 1]);
        return 2;
      }
    }
  }
  std::string out;
  std::vector<double> lo, hi, rlo, rhi;
  std::vector<uint8_t> rnan;
  for (size_t start = 0; start < n; start += kBlock) {
    const size_t m = std::min(kBlock, n - start);
    lo.assign(m * std::max(dims, 1), 0.0);
    hi.assign(lo.size(), 0.0);
    for (size_t i = 0; i < m; ++i) {
      for (int k = 0; k < dims; ++k) {
        lo[k * m + i] = rows[(start + i) * 2 * dims + 2 * k];
        hi[k * m + i] = rows[(start + i) * 2 * dims + 2 * k + 1];
      }
    }
    rlo.assign(m, 0.0);
    rhi.assign(m, 0.0);
    rnan.assign(m, 0);
    model.eval_interval_batch(static_cast<int64_t>(m), lo.data(), hi.data(), rlo.data(), rhi.data(),
                              rnan.data());
    for (size_t i = 0; i < m; ++i) {
      append_number(out, rlo[i]);
      out += ' ';
      append_number(out, rhi[i]);
      if (rnan[i]) out += " nan";
      out += '\n';
    }
    std::fwrite(out.data(), 1, out.size(), stdout);
    out.clear();
  }
  return 0;
}

/// `--gradient`: points from stdin, `f dfdx dfdy dfdz` per point.
int eval_gradients(const Model& model, bool f32, size_t* count) {
  const int dims = model.num_inputs();
  std::vector<double> rows;
  if (!read_points(dims, &rows, count)) return 2;
  const size_t n = *count;
  std::string out;
  std::vector<double> xs, g;
  std::vector<float> xs32, g32;
  for (size_t start = 0; start < n; start += kBlock) {
    const size_t m = std::min(kBlock, n - start);
    xs.assign(m * std::max(dims, 1), 0.0);
    for (size_t i = 0; i < m; ++i) {
      for (int k = 0; k < dims; ++k) xs[k * m + i] = rows[(start + i) * dims + k];
    }
    g.assign(4 * m, 0.0);
    if (f32) {
      xs32.assign(xs.begin(), xs.end());
      g32.assign(4 * m, 0.0f);
      model.eval_gradient_batch(static_cast<int64_t>(m), xs32.data(), g32.data());
      g.assign(g32.begin(), g32.end());
    } else {
      model.eval_gradient_batch(static_cast<int64_t>(m), xs.data(), g.data());
    }
    for (size_t i = 0; i < m; ++i) {
      for (int c = 0; c < 4; ++c) {
        if (c) out += ' ';
        append_number(out, g[c * m + i]);
      }
      out += '\n';
    }
    std::fwrite(out.data(), 1, out.size(), stdout);
    out.clear();
  }
  return 0;
}

int run_eval(const EvalOptions& opts) {
  if (opts.interval && opts.gradient) {
    std::fprintf(stderr, "hfrt: --interval and --gradient exclude each other\n");
    return 2;
  }
  if (opts.interval && opts.precision == "f32") {
    std::fprintf(stderr, "hfrt: --interval evaluates in f64 only (drop --precision f32)\n");
    return 2;
  }
  ModelOptions mo;
  mo.object = opts.object;
  mo.backend = opts.backend == "interp" ? Backend::kInterp : Backend::kJit;
  mo.opt_level = opts.opt_level;
  mo.limits = opts.limits;
  const bool f32 = opts.precision == "f32";
  // The scalar code is needed only without --interval/--gradient (those compile their own).
  const bool scalar = !opts.interval && !opts.gradient;
  mo.eager_f64 = scalar && !f32;
  mo.eager_f32 = scalar && f32;
  std::vector<double> params;
  if (!parse_params(opts.params, &params)) {
    std::fprintf(stderr, "hfrt: -a expects numbers separated by commas, e.g. -a 1,0.5 (got '%s')\n",
                 opts.params.c_str());
    return 2;
  }

  auto t0 = std::chrono::steady_clock::now();
  CompileResult compiled = Model::compile_file(opts.file, mo);
  const double compile_ms = ms_since(t0);
  if (!compiled.error.empty()) {
    std::fprintf(stderr, "hfrt: %s\n", compiled.error.c_str());
    return 2;
  }
  std::fputs(compiled.rendered.c_str(), stderr);
  if (!compiled.ok()) return 1;
  Model& model = *compiled.model;
  model.set_params(params);

  size_t n = 0;
  t0 = std::chrono::steady_clock::now();
  if (!scalar) {
    int code = opts.interval ? eval_boxes(model, &n) : eval_gradients(model, f32, &n);
    std::fflush(stdout);
    if (code != 0) return code;
    if (opts.stats) {
      const double eval_ms = ms_since(t0);
      ModelStats st = model.stats();
      const DomainEngine engine =
          opts.interval ? model.interval_engine()
                        : model.gradient_engine(f32 ? Precision::kF32 : Precision::kF64);
      const char* engine_name = engine == DomainEngine::kJit      ? "jit"
                                : engine == DomainEngine::kTapeVm ? "tape VM"
                                                                  : "interpreter";
      const ModelStats::Domain& d = opts.interval ? st.interval
                                    : f32         ? st.gradient_f32
                                                  : st.gradient_f64;
      std::fprintf(stderr,
                   "stats: object %s, %d IR instructions (domain JIT weight %lld), %s domain, "
                   "engine %s\n",
                   model.object_name().c_str(), st.ir_insts, (long long)st.domain_jit_weight,
                   opts.interval ? "interval" : "gradient", engine_name);
      std::fprintf(stderr, "stats: compile %.3f ms (front end %.3f ms, lowering %.3f ms)\n",
                   compile_ms, st.frontend_ms, st.lower_ms);
      if (d.compiled) {
        std::fprintf(stderr, "stats: %s jit: %d lanes, compiled in %.3f ms (on first use)\n",
                     opts.interval ? "interval" : "gradient", d.lanes, d.compile_ms);
      }
      std::fprintf(stderr, "stats: evaluated %zu %s in %.3f ms (incl. JIT compile and output)\n", n,
                   opts.interval ? "boxes" : "points", eval_ms);
    }
    return 0;
  }

  const int dims = model.num_inputs();
  const int ns = model.num_attributes();
  std::vector<double> rows;
  if (!read_points(dims, &rows, &n)) return 2;

  std::string out;
  std::vector<double> xs, f, s;
  std::vector<float> xs32, f32v, s32;
  for (size_t start = 0; start < n; start += kBlock) {
    const size_t m = std::min(kBlock, n - start);
    f.assign(m, 0.0);
    s.assign(m * ns, 0.0);
    if (f32) {
      xs32.assign(m * dims, 0.0f);
      for (size_t i = 0; i < m; ++i) {
        for (int k = 0; k < dims; ++k)
          xs32[k * m + i] = static_cast<float>(rows[(start + i) * dims + k]);
      }
      f32v.assign(m, 0.0f);
      s32.assign(m * ns, 0.0f);
      model.eval_batch(static_cast<int64_t>(m), xs32.data(), f32v.data(),
                       ns ? s32.data() : nullptr);
      for (size_t i = 0; i < m; ++i) f[i] = f32v[i];
      for (size_t i = 0; i < m * ns; ++i) s[i] = s32[i];
    } else {
      xs.assign(m * dims, 0.0);
      for (size_t i = 0; i < m; ++i) {
        for (int k = 0; k < dims; ++k) xs[k * m + i] = rows[(start + i) * dims + k];
      }
      model.eval_batch(static_cast<int64_t>(m), xs.data(), f.data(), ns ? s.data() : nullptr);
    }
    for (size_t i = 0; i < m; ++i) {
      if (std::isnan(f[i])) {
        // Explain the NaN: the interpreter knows the first run-time error and its place.
        PointValue pv = model.eval(std::span<const double>(&rows[(start + i) * dims], dims));
        if (!pv.ok()) {
          out += "nan ";
          out += pv.error;
          if (pv.error_line > 0) {
            out += " (line " + std::to_string(pv.error_line) + " pos " +
                   std::to_string(pv.error_col) + ")";
          }
          out += '\n';
          continue;
        }
      }
      append_number(out, f[i]);
      for (int k = 0; k < ns; ++k) {
        out += ' ';
        append_number(out, s[k * m + i]);
      }
      out += '\n';
    }
    std::fwrite(out.data(), 1, out.size(), stdout);
    out.clear();
  }
  std::fflush(stdout);
  const double eval_ms = ms_since(t0);

  if (opts.stats) {
    ModelStats st = model.stats();
    std::fprintf(stderr, "stats: object %s, %d IR instructions, backend %s, precision %s\n",
                 model.object_name().c_str(), st.ir_insts, opts.backend.c_str(),
                 opts.precision.c_str());
    std::fprintf(stderr, "stats: compile %.3f ms (front end %.3f ms, lowering %.3f ms)\n",
                 compile_ms, st.frontend_ms, st.lower_ms);
    for (const ModelStats::Jit* j : {&st.jit_f64, &st.jit_f32}) {
      if (!j->compiled) continue;
      std::fprintf(stderr,
                   "stats: jit %s: %d lanes, emit %.3f ms, optimise %.3f ms, codegen %.3f ms, "
                   "LLVM instructions %zu -> %zu, %zu calls%s\n",
                   j == &st.jit_f64 ? "f64" : "f32", j->lanes, j->emit_ms, j->optimize_ms,
                   j->codegen_ms, j->llvm_insts_before, j->llvm_insts_after, j->llvm_calls,
                   j->fast_codegen ? " (fast code generation: too many calls)" : "");
    }
    std::fprintf(stderr, "stats: evaluated %zu points in %.3f ms (%.1f ns/point, incl. output)\n",
                 n, eval_ms, n ? eval_ms * 1e6 / static_cast<double>(n) : 0.0);
  }
  return 0;
}

}  // namespace

CommandRunner register_eval(CLI::App& app) {
  auto opts = std::make_shared<EvalOptions>();
  CLI::App* sub = add_command(app, "eval");
  sub->add_option("model", opts->file, "HyperFun model file")->required();
  sub->add_option("--object", opts->object, "object to evaluate (default: my_model or the first)");
  sub->add_option("-a", opts->params, "parameter values a[1],a[2],... separated by commas");
  sub->add_option("--backend", opts->backend, "evaluator: jit (default) or interp")
      ->check(CLI::IsMember({"jit", "interp"}));
  sub->add_option("--precision", opts->precision, "f64 (default) or f32")
      ->check(CLI::IsMember({"f64", "f32"}));
  sub->add_option("-O,--opt-level", opts->opt_level, "LLVM optimisation level 0..3 (default 2)")
      ->check(CLI::Range(0, 3));
  sub->add_flag("--interval", opts->interval,
                "read boxes 'x0 x1 y0 y1 z0 z1' and print an enclosure 'lo hi' of F (' nan' "
                "appended when the box may hold points without a value)");
  sub->add_flag("--gradient", opts->gradient,
                "print 'f dfdx dfdy dfdz' per point (automatic differentiation)");
  sub->add_flag("--stats", opts->stats, "print compile and evaluation times on stderr");
  add_limit_options(*sub, &opts->limits);
  return [opts] { return run_eval(*opts); };
}

}  // namespace hfrt::tools
