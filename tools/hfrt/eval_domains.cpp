// The interval and gradient modes of `hfrt eval` (see eval_domains.h).

#include "tools/hfrt/eval_domains.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <iterator>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "jit/gradient.h"
#include "jit/interval.h"
#include "jit/ir.h"
#include "jit/lower.h"
#include "lang/frontend.h"
#include "lang/result.h"
#include "tools/hfrt/commands.h"

namespace hfrt::tools {
namespace {

/// Parses and lowers the selected object; prints diagnostics on stderr. nullopt with *code
/// set when there is nothing to evaluate.
std::optional<jit::Function> load(const DomainEvalOptions& o, int* code) {
  Result<std::string> text = read_file(o.file);
  if (!text.ok()) {
    std::fprintf(stderr, "hfrt: %s\n", text.error().message.c_str());
    *code = 2;
    return std::nullopt;
  }
  auto file = std::make_shared<const lang::SourceFile>(o.file, std::move(text.value()));
  lang::DiagnosticSink diags(file);
  std::unique_ptr<lang::Program> program = lang::compile_source(file, diags);
  std::fputs(diags.render(use_color(2)).c_str(), stderr);
  if (!program) {
    *code = 1;
    return std::nullopt;
  }
  int index = o.object.empty() ? program->default_object() : program->find_object(o.object);
  if (index < 0) {
    std::fprintf(stderr, "hfrt: no object named '%s' in %s\n", o.object.c_str(), o.file.c_str());
    *code = 2;
    return std::nullopt;
  }
  lang::DiagnosticSink warnings(file);
  jit::Function fn = jit::lower_object(*program, index, &warnings);
  return fn;
}

/// Reads whitespace-separated numbers per non-blank, non-comment line of stdin.
bool read_rows(std::vector<std::vector<double>>* rows) {
  std::string text((std::istreambuf_iterator<char>(std::cin)), std::istreambuf_iterator<char>());
  size_t pos = 0, line_no = 0;
  while (pos < text.size()) {
    size_t eol = text.find('\n', pos);
    if (eol == std::string::npos) eol = text.size();
    std::string line = text.substr(pos, eol - pos);
    pos = eol + 1;
    ++line_no;
    size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::vector<double> row;
    const char* c = line.c_str();
    for (;;) {
      while (*c == ' ' || *c == '\t' || *c == '\r') ++c;
      if (!*c) break;
      char* end = nullptr;
      double v = std::strtod(c, &end);
      if (end == c || (*end && *end != ' ' && *end != '\t' && *end != '\r')) {
        std::fprintf(stderr, "hfrt: stdin line %zu: cannot read '%s' as a number\n", line_no,
                     std::string(c, std::strcspn(c, " \t\r")).c_str());
        return false;
      }
      row.push_back(v);
      c = end;
    }
    rows->push_back(std::move(row));
  }
  return true;
}

void append(std::string& out, double v) {
  if (std::isnan(v)) {
    out += "nan";
    return;
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  out += buf;
}

}  // namespace

int run_eval_interval(const DomainEvalOptions& o) {
  int code = 0;
  std::optional<jit::Function> fn = load(o, &code);
  if (!fn) return code;
  std::vector<std::vector<double>> rows;
  if (!read_rows(&rows)) return 2;
  jit::IntervalInterpreter ii(*fn);
  std::string out;
  std::vector<jit::Interval> box(fn->num_inputs);
  for (const auto& row : rows) {
    for (int k = 0; k < fn->num_inputs; ++k) {
      double lo = 2 * k < static_cast<int>(row.size()) ? row[2 * k] : 0.0;
      double hi = 2 * k + 1 < static_cast<int>(row.size()) ? row[2 * k + 1] : lo;
      if (!(lo <= hi)) {
        std::fprintf(stderr, "hfrt: box coordinate %d: lower bound %g above upper bound %g\n",
                     k + 1, lo, hi);
        return 2;
      }
      box[k] = {lo, hi, false};
    }
    jit::Interval r = ii.eval(box, o.params);
    append(out, r.lo);
    out += ' ';
    append(out, r.hi);
    if (r.maybe_nan) out += " nan";
    out += '\n';
  }
  std::fwrite(out.data(), 1, out.size(), stdout);
  std::fflush(stdout);
  return 0;
}

int run_eval_gradient(const DomainEvalOptions& o) {
  int code = 0;
  std::optional<jit::Function> fn = load(o, &code);
  if (!fn) return code;
  std::vector<std::vector<double>> rows;
  if (!read_rows(&rows)) return 2;
  jit::GradientInterpreter gi(*fn);
  std::string out;
  for (auto& row : rows) {
    row.resize(std::max<size_t>(row.size(), fn->num_inputs), 0.0);
    jit::Dual d = gi.eval(row, o.params);
    append(out, d.v);
    for (double c : d.d) {
      out += ' ';
      append(out, c);
    }
    out += '\n';
  }
  std::fwrite(out.data(), 1, out.size(), stdout);
  std::fflush(stdout);
  return 0;
}

}  // namespace hfrt::tools
