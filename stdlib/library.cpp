// Entry point of the FRep library: dispatch to the family files, the per-call context
// (array slots, size warnings) and hfR.
#include "stdlib/library.h"

#include <iomanip>
#include <sstream>

#include "base/check.h"
#include "stdlib/lib_util.h"

namespace hfrt::stdlib {
namespace detail {

Call::Call(LibraryFn fn, LibContext& ctx, std::span<const LibArg> args)
    : fn_(fn), ctx_(ctx), args_(args) {
  const std::string_view kinds = lang::library_fn_kinds(fn);
  HFRT_CHECK_MSG(kinds.size() == args.size(),
                 "library call " << name() << " with " << args.size() << " arguments");
  for (size_t i = 0; i < args.size(); ++i) {
    const bool want_array = kinds[i] == 'A';
    HFRT_CHECK_MSG(args[i].is_array == want_array,
                   name() << " argument " << i + 1 << " has the wrong kind");
    if (kinds[i] == 'F') continue;  // a file name: LibArg::text
    if (want_array) {
      HFRT_CHECK(args[i].size >= 0 && args[i].base_slot >= 0);
      HFRT_CHECK_LE(args[i].base_slot + args[i].size, ctx.b.function().num_slots);
    } else {
      HFRT_CHECK(args[i].value != ir::kNoValue);
    }
  }
}

std::string_view Call::name() const {
  return lang::library_fn_name(fn_);
}

V Call::real(int i) const {
  HFRT_CHECK(!args_[i].is_array);
  return {&ctx_.b, args_[i].value};
}

bool Call::real_constant(int i, double* out) const {
  const ir::Inst& inst = ctx_.b.function().insts.at(real(i).id);
  if (inst.op != Op::kConst) return false;
  *out = inst.imm;
  return true;
}

int Call::size(int i) const {
  HFRT_CHECK(args_[i].is_array);
  return args_[i].size;
}

V Call::at(int i, int k) {
  if (k < 0 || k >= size(i)) return nan();
  return {&ctx_.b, ctx_.b.load(args_[i].base_slot + k)};
}

V Call::at_index(int i, V index1) {
  HFRT_CHECK_LT(0, size(i));
  return {&ctx_.b, ctx_.b.load_index(args_[i].base_slot, size(i), index1.id)};
}

void Call::put(int i, int k, V v) {
  if (k < 0 || k >= size(i)) return;
  ctx_.b.store(args_[i].base_slot + k, v.id);
}

bool Call::point3(int i, double failure) {
  if (size(i) == 3) return true;
  std::ostringstream msg;
  msg << name() << ": the point array '" << arg_text(i) << "' has " << size(i)
      << " elements, not 3; the call returns the failure value " << std::fixed
      << std::setprecision(1) << failure;
  warn(i, msg.str(), "pass an array of exactly 3 elements (e.g. a local copy of x[1..3])");
  return false;
}

bool Call::need(int i, int count, std::string_view what) {
  if (size(i) >= count) return true;
  std::ostringstream msg;
  msg << name() << ": array '" << arg_text(i) << "' has " << size(i)
      << " elements but the call reads " << count << " (" << what
      << "); the missing elements read as NaN";
  warn(i, msg.str(), "declare the array with enough elements");
  return false;
}

void Call::error(int i, const std::string& message, const std::string& hint) {
  if (ctx_.diags == nullptr) return;
  ctx_.diags->error(i < 0 ? ctx_.call_range : args_[i].range, message, hint);
}

const std::string& Call::text(int i) const {
  return args_[i].text;
}

void Call::warn(int i, const std::string& message, const std::string& hint) {
  if (ctx_.diags == nullptr) return;
  ctx_.diags->warning(i < 0 ? ctx_.call_range : args_[i].range, message, hint);
}

std::string Call::arg_text(int i) const {
  const lang::SourceRange& r = args_[i].range;
  if (ctx_.diags != nullptr && ctx_.diags->file() != nullptr && r.length > 0) {
    std::string_view text = ctx_.diags->file()->text();
    if (r.begin.offset + r.length <= text.size()) {
      return std::string(text.substr(r.begin.offset, r.length));
    }
  }
  return "argument " + std::to_string(i + 1);
}

namespace {

// hfR exists only in the R-package build (library.md §11): nothing to call here.
V lower_hfr(Call& c) {
  c.warn(-1, "hfR needs the R package build of HyperFun; it returns the failure value here",
         "hfR calls back into an embedded R session, which hfrt does not have");
  return c.k(kFailure);
}

}  // namespace
}  // namespace detail

ir::ValueId lower_library_call(lang::LibraryFn fn, LibContext& ctx, std::span<const LibArg> args) {
  using lang::LibraryFn;
  detail::Call call(fn, ctx, args);
  detail::V v;
  switch (fn) {
    case LibraryFn::kSphere:
    case LibraryFn::kEllipsoid:
    case LibraryFn::kTorusX:
    case LibraryFn::kTorusY:
    case LibraryFn::kTorusZ:
    case LibraryFn::kEllCylX:
    case LibraryFn::kEllCylY:
    case LibraryFn::kEllCylZ:
    case LibraryFn::kCylinderX:
    case LibraryFn::kCylinderY:
    case LibraryFn::kCylinderZ:
    case LibraryFn::kBlock:
    case LibraryFn::kBlobby:
    case LibraryFn::kMetaball:
    case LibraryFn::kSoft:
    case LibraryFn::kNoiseG:
    case LibraryFn::kSuperell:
    case LibraryFn::kConeX:
    case LibraryFn::kConeY:
    case LibraryFn::kConeZ:
    case LibraryFn::kEllConeX:
    case LibraryFn::kEllConeY:
    case LibraryFn::kEllConeZ:
      v = detail::lower_primitive(call);
      break;
    case LibraryFn::kBezierVolume:
      v = detail::lower_bezier(call);
      break;
    case LibraryFn::kConvPoint:
    case LibraryFn::kConvLine:
    case LibraryFn::kConvArc:
    case LibraryFn::kConvTriangle:
    case LibraryFn::kConvLineR:
    case LibraryFn::kConvCurve:
    case LibraryFn::kConvMesh:
      v = detail::lower_convolution(call);
      break;
    case LibraryFn::kScale3D:
    case LibraryFn::kShift3D:
    case LibraryFn::kRotate3DX:
    case LibraryFn::kRotate3DY:
    case LibraryFn::kRotate3DZ:
    case LibraryFn::kTwistX:
    case LibraryFn::kTwistY:
    case LibraryFn::kTwistZ:
    case LibraryFn::kStretch3D:
    case LibraryFn::kTaperX:
    case LibraryFn::kTaperY:
    case LibraryFn::kTaperZ:
    case LibraryFn::kSpaceMapCubic:
    case LibraryFn::kSpaceMapExp:
      v = detail::lower_transform(call);
      break;
    case LibraryFn::kBlendUni:
    case LibraryFn::kBlendInt:
    case LibraryFn::kDBlendUni:
    case LibraryFn::kDBlendInt:
    case LibraryFn::kSawtooth:
      v = detail::lower_blend(call);
      break;
    case LibraryFn::kDConeX:
    case LibraryFn::kDConeY:
    case LibraryFn::kDConeZ:
    case LibraryFn::kDCylinder:
    case LibraryFn::kDEllipsoid:
    case LibraryFn::kDTorusX:
    case LibraryFn::kDTorusY:
    case LibraryFn::kDTorusZ:
      v = detail::lower_distance(call);
      break;
    case LibraryFn::kDUni:
    case LibraryFn::kDInt:
    case LibraryFn::kDSub:
      v = detail::lower_sardf(call);
      break;
    case LibraryFn::kANoiseG:
    case LibraryFn::kANoiseP:
    case LibraryFn::kATurbulence:
    case LibraryFn::kACrackles:
      v = detail::lower_noise(call);
      break;
    case LibraryFn::kR:
      v = detail::lower_hfr(call);
      break;
    case LibraryFn::kAWave:
    case LibraryFn::kACheckerBoard:
    case LibraryFn::kAUnion:
    case LibraryFn::kACircles:
    case LibraryFn::kASetColor:
    case LibraryFn::kASetAttributes:
    case LibraryFn::kALerp:
    case LibraryFn::kACerp:
    case LibraryFn::kAClamp:
    case LibraryFn::kAFloor:
    case LibraryFn::kAPulse:
    case LibraryFn::kALookUpTable:
    case LibraryFn::kASmoothLookUpTable:
    case LibraryFn::kAStep:
    case LibraryFn::kASmoothStep:
    case LibraryFn::kAModulo:
    case LibraryFn::kASpline:
    case LibraryFn::kARGBToHSV:
    case LibraryFn::kAHSVToRGB:
      v = detail::lower_attribute(call);
      break;
    case LibraryFn::kMesh:
    case LibraryFn::kTriangles:
    case LibraryFn::kBezierSurface:
    case LibraryFn::kBezierPatches:
      v = detail::lower_surface(call);
      break;
  }
  HFRT_CHECK_MSG(v.id != ir::kNoValue, "no IR for " << lang::library_fn_name(fn));
  return v.id;
}

}  // namespace hfrt::stdlib
