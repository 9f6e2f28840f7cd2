// Fuzz target: the front end (lang/). Any bytes -> parse_program + check_program ->
// diagnostics, rendered, and the AST dumped. The contract of lang/frontend.h: never a crash,
// hang or out-of-bounds read, whatever the bytes; a failed check has an error diagnostic.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "base/check.h"
#include "lang/diagnostics.h"
#include "lang/frontend.h"
#include "lang/source.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace hfrt::lang;
  auto file = std::make_shared<const SourceFile>(
      "fuzz.hf", std::string(reinterpret_cast<const char*>(data), size));
  DiagnosticSink diags(file);
  std::unique_ptr<Program> program = parse_program(file, diags);
  HFRT_CHECK(program != nullptr);
  const bool parsed = !diags.has_errors();
  const bool checked = check_program(*program, diags);
  // A program that checks has no error diagnostics, and one that does not has at least one.
  HFRT_CHECK(checked == !diags.has_errors());
  if (parsed) (void)dump_ast(*program);
  (void)diags.render(false);
  (void)diags.render(true);
  return 0;
}
