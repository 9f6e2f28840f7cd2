#pragma once
// The front end's entry points: text -> checked AST, with diagnostics.

#include <memory>
#include <string>

#include "base/limits.h"
#include "lang/ast.h"
#include "lang/diagnostics.h"

namespace hfrt::lang {

/// Parses a whole file. Recovers from errors and reports all of them (up to the sink's
/// limit). Never crashes, hangs or reads out of bounds, whatever the bytes. Returns the
/// objects it could parse (possibly none). Array sizes above limits.max_array_size are errors
/// (the other limits are the lowering's).
std::unique_ptr<Program> parse_program(std::shared_ptr<const SourceFile> file,
                                       DiagnosticSink& diags, const Limits& limits = {});

/// Semantic checks; resolves every name to a Symbol and numbers local scalars. Adds errors
/// and warnings to `diags`. Returns false when there were errors.
bool check_program(Program& program, DiagnosticSink& diags);

/// parse_program + check_program. Returns nullptr when the file has errors.
std::unique_ptr<Program> compile_source(std::shared_ptr<const SourceFile> file,
                                        DiagnosticSink& diags, const Limits& limits = {});

/// A stable, indented text form of the AST (`hfrt check --dump-ast`, golden tests).
std::string dump_ast(const Program& program);

}  // namespace hfrt::lang
