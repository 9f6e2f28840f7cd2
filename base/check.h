#pragma once
// HFRT_CHECK: broken invariants (bugs in hfrt, never user errors) abort with the condition,
// the location and, for the binary forms, both values. Always on, also in Release builds.

#include <sstream>
#include <string>

namespace hfrt {
[[noreturn]] void check_failed(const char* file, int line, const std::string& what);
}  // namespace hfrt

#define HFRT_CHECK(cond)                                          \
  do {                                                            \
    if (!(cond)) ::hfrt::check_failed(__FILE__, __LINE__, #cond); \
  } while (0)

#define HFRT_CHECK_MSG(cond, msg)                                     \
  do {                                                                \
    if (!(cond)) {                                                    \
      std::ostringstream hfrt_check_os_;                              \
      hfrt_check_os_ << #cond << ": " << msg;                         \
      ::hfrt::check_failed(__FILE__, __LINE__, hfrt_check_os_.str()); \
    }                                                                 \
  } while (0)

#define HFRT_CHECK_OP(a, op, b)                                                        \
  do {                                                                                 \
    const auto& hfrt_a_ = (a);                                                         \
    const auto& hfrt_b_ = (b);                                                         \
    if (!(hfrt_a_ op hfrt_b_)) {                                                       \
      std::ostringstream hfrt_check_os_;                                               \
      hfrt_check_os_ << #a " " #op " " #b " (" << hfrt_a_ << " vs " << hfrt_b_ << ")"; \
      ::hfrt::check_failed(__FILE__, __LINE__, hfrt_check_os_.str());                  \
    }                                                                                  \
  } while (0)

#define HFRT_CHECK_EQ(a, b) HFRT_CHECK_OP(a, ==, b)
#define HFRT_CHECK_NE(a, b) HFRT_CHECK_OP(a, !=, b)
#define HFRT_CHECK_LT(a, b) HFRT_CHECK_OP(a, <, b)
#define HFRT_CHECK_LE(a, b) HFRT_CHECK_OP(a, <=, b)
#define HFRT_CHECK_GE(a, b) HFRT_CHECK_OP(a, >=, b)
