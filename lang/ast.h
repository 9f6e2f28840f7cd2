#pragma once
// The abstract syntax tree of a HyperFun file. Produced by the parser, annotated in place by
// the semantic checks (symbols resolved, locals numbered), consumed by jit/ lowering and by
// `hfrt check --dump-ast`. Plain data: no behaviour lives on the nodes.

#include <memory>
#include <string>
#include <vector>

#include "lang/source.h"

namespace hfrt::lang {

enum class UnaryOp {
  kNeg,         ///< -e
  kPlus,        ///< +e
  kComplement,  ///< ~e (set complement, = -e)
  kNot,         ///< not c (conditions only)
};

enum class BinaryOp {
  kAdd,
  kSub,
  kMul,
  kDiv,
  kPow,
  kUnion,      ///< |  R-function union
  kIntersect,  ///< &  R-function intersection
  kSubtract,   ///< \  R-function subtraction
  kProduct,    ///< @  Cartesian product (= intersection formula)
  // Conditions only (after `if` / `while`): produce 1 or 0.
  kLt,
  kLe,
  kGt,
  kGe,
  kEq,
  kNe,
  kAnd,
  kOr,
};

/// What a name refers to. Filled in by the semantic checks.
enum class SymbolKind {
  kUnresolved,
  kLocalScalar,  ///< index = Object::scalars position
  kLocalArray,   ///< index = Object::arrays position
  kX,
  kA,
  kS,        ///< the header arrays; index unused
  kBuiltin,  ///< index = static_cast<int>(Builtin)
  kLibrary,  ///< index = static_cast<int>(LibraryFn)
  kObject,   ///< index = Program::objects position (always < the caller's)
};

struct Symbol {
  SymbolKind kind = SymbolKind::kUnresolved;
  int index = -1;
};

enum class ExprKind {
  kNumber,  ///< number
  kName,    ///< a bare name: a local scalar, or an array name passed as a call argument
  kIndex,   ///< name[args[0]]: element of x, a, s or a local array
  kUnary,   ///< unary_op args[0]
  kBinary,  ///< args[0] binary_op args[1]
  kCall,    ///< name(args...): built-in, library function or earlier object
  kString,  ///< "text": only the file argument of hfMesh / hfBezierSurface (name = the text)
};

struct Expr;
using ExprPtr = std::unique_ptr<Expr>;

struct Expr {
  ExprKind kind = ExprKind::kNumber;
  SourceRange range;  ///< the whole expression
  double number = 0;  ///< kNumber
  std::string name;   ///< kName, kIndex, kCall: as written; kString: the text between the quotes
  SourceRange name_range;  ///< kName, kIndex, kCall
  Symbol symbol;           ///< kName, kIndex, kCall (after checking)
  UnaryOp unary_op = UnaryOp::kNeg;
  BinaryOp binary_op = BinaryOp::kAdd;
  std::vector<ExprPtr> args;  ///< operands, index or call arguments
};

enum class StmtKind {
  kAssign,       ///< name = value
  kAssignIndex,  ///< name[index] = value
  kAssignArray,  ///< name = [literal...]
  kIf,           ///< if cond then then_body [else else_body] endif;
  kWhile,        ///< while cond loop then_body endloop;
};

struct Stmt;
using StmtPtr = std::unique_ptr<Stmt>;

struct Stmt {
  StmtKind kind = StmtKind::kAssign;
  SourceRange range;
  std::string name;  ///< assignment target as written
  SourceRange name_range;
  Symbol symbol;                   ///< assignment target (after checking)
  ExprPtr index;                   ///< kAssignIndex
  ExprPtr value;                   ///< kAssign, kAssignIndex
  std::vector<double> literal;     ///< kAssignArray
  ExprPtr cond;                    ///< kIf, kWhile
  std::vector<StmtPtr> then_body;  ///< kIf then-part, kWhile body
  std::vector<StmtPtr> else_body;  ///< kIf else-part
  bool has_else = false;
};

struct ArrayDecl {
  std::string name;
  int size = 0;
  SourceRange range;
};

/// One object `name(x[n], a[m] [, s[k]]) { ... name = expr; }`.
struct Object {
  std::string name;
  SourceRange name_range;
  SourceRange range;  ///< the whole definition
  int x_size = 0;
  int a_size = 0;
  int s_size = 0;  ///< 0 when the header has no s
  bool has_s = false;
  std::vector<ArrayDecl> arrays;     ///< local arrays, in declaration order
  std::vector<std::string> scalars;  ///< local scalars in first-assignment order (by checking)
  std::vector<StmtPtr> body;         ///< statements before the model assignment
  ExprPtr result;                    ///< the right side of the final `name = expr;`
  SourceRange result_range;          ///< the final assignment statement
  /// Set by the parser when this object's text had syntax errors: its AST is a partial
  /// recovery, so the semantic checks skip its body (they would only report follow-ups).
  bool had_syntax_errors = false;
};

/// A parsed file. Keeps its source alive so that every SourceRange stays meaningful.
struct Program {
  std::shared_ptr<const SourceFile> source;
  std::vector<Object> objects;

  /// The model by the rule of the spec: `my_model` if present, else the first object.
  /// -1 when there are no objects.
  int default_object() const;
  /// The object with this name (case-insensitive), or -1.
  int find_object(std::string_view name) const;
  /// The object a command asked for: `name`, or the default object when `name` is empty.
  /// When there is none, -1 with the message ("no object named 'x' in the file", "the file
  /// defines no object") and a hint listing the objects there are (empty when none).
  int select_object(std::string_view name, std::string* message, std::string* hint) const;
};

}  // namespace hfrt::lang
