#pragma once
// Limits of the parser (the entry point is parse_program in lang/frontend.h). They exist so
// that hostile or generated input cannot exhaust the stack or memory: every recursive walker
// over the AST (checks, dump, lowering, destruction) relies on the depth bounds below.

#include <cstdint>

namespace hfrt::lang {

/// Deepest nesting of parentheses, calls, unary operators, conditions and if/while blocks.
/// The recursive-descent parser recurses once per level.
inline constexpr int kMaxNesting = 256;

/// Deepest chain of binary operators. Left-associative chains (`a+b+c+...`) are built
/// without parser recursion but still give deep trees; beyond this the parser reports an
/// error. With the nesting limit above, no expression tree is deeper than
/// kMaxExprDepth + kMaxNesting nodes, and no statement list nests deeper than kMaxNesting.
inline constexpr int kMaxExprDepth = 1000;

// The largest array size is not fixed: Limits::max_array_size (base/limits.h), an argument of
// parse_program.

}  // namespace hfrt::lang
