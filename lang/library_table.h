#pragma once
// Signatures of the FRep library functions (../shared/spec/library.md, table order of the
// original). The front end checks calls against this table; stdlib/ implements each entry.

#include <optional>
#include <string_view>

namespace hfrt::lang {

// X(enum_name, spelled_name, kinds). kinds: one letter per argument in call order,
// 'A' = an array name (passed by reference), 'R' = a real expression, 'F' = a file name as a
// string literal (the only place a string is accepted; an hfrt extension).
#define HFRT_LIBRARY(X)                                                          \
  X(kSphere, "hfSphere", "AAR")                                                  \
  X(kEllipsoid, "hfEllipsoid", "AARRR")                                          \
  X(kTorusZ, "hfTorusZ", "AARR")                                                 \
  X(kTorusX, "hfTorusX", "AARR")                                                 \
  X(kTorusY, "hfTorusY", "AARR")                                                 \
  X(kEllCylX, "hfEllCylX", "AARR")                                               \
  X(kEllCylY, "hfEllCylY", "AARR")                                               \
  X(kEllCylZ, "hfEllCylZ", "AARR")                                               \
  X(kCylinderX, "hfCylinderX", "AAR")                                            \
  X(kCylinderY, "hfCylinderY", "AAR")                                            \
  X(kCylinderZ, "hfCylinderZ", "AAR")                                            \
  X(kBlock, "hfBlock", "AARRR")                                                  \
  X(kBlobby, "hfBlobby", "AAAAAAR")                                              \
  X(kMetaball, "hfMetaball", "AAAAAAR")                                          \
  X(kSoft, "hfSoft", "AAAAAR")                                                   \
  X(kScale3D, "hfScale3D", "ARRR")                                               \
  X(kShift3D, "hfShift3D", "ARRR")                                               \
  X(kRotate3DZ, "hfRotate3DZ", "AR")                                             \
  X(kRotate3DY, "hfRotate3DY", "AR")                                             \
  X(kRotate3DX, "hfRotate3DX", "AR")                                             \
  X(kBlendUni, "hfBlendUni", "RRRRR")                                            \
  X(kBlendInt, "hfBlendInt", "RRRRR")                                            \
  X(kTwistZ, "hfTwistZ", "ARRRR")                                                \
  X(kTwistY, "hfTwistY", "ARRRR")                                                \
  X(kTwistX, "hfTwistX", "ARRRR")                                                \
  X(kStretch3D, "hfStretch3D", "AARRR")                                          \
  X(kTaperZ, "hfTaperZ", "ARRRR")                                                \
  X(kTaperY, "hfTaperY", "ARRRR")                                                \
  X(kTaperX, "hfTaperX", "ARRRR")                                                \
  X(kConvPoint, "hfConvPoint", "AAAR")                                           \
  X(kConvLine, "hfConvLine", "AAAAR")                                            \
  X(kConvArc, "hfConvArc", "AAAAAAAR")                                           \
  X(kConvTriangle, "hfConvTriangle", "AAAR")                                     \
  X(kBezierVolume, "hfBezierVolume", "ARRRAA")                                   \
  X(kConvLineR, "hfConvLineR", "AAAR")                                           \
  X(kConvCurve, "hfConvCurve", "AAAR")                                           \
  X(kConvMesh, "hfConvMesh", "AAAAR")                                            \
  X(kNoiseG, "hfNoiseG", "ARRR")                                                 \
  X(kSuperell, "hfSuperell", "AARRRRR")                                          \
  X(kConeX, "hfConeX", "AAR")                                                    \
  X(kConeY, "hfConeY", "AAR")                                                    \
  X(kConeZ, "hfConeZ", "AAR")                                                    \
  X(kEllConeX, "hfEllConeX", "AARR")                                             \
  X(kEllConeY, "hfEllConeY", "AARR")                                             \
  X(kEllConeZ, "hfEllConeZ", "AARR")                                             \
  X(kSpaceMapCubic, "hfSpaceMapCubic", "AAAA")                                   \
  X(kSpaceMapExp, "hfSpaceMapExp", "AAAA")                                       \
  X(kR, "hfR", "AR")                                                             \
  X(kAWave, "hfA_Wave", "RRRR")                                                  \
  X(kACheckerBoard, "hfA_CheckerBoard", "AAAAAA")                                \
  X(kAUnion, "hfA_Union", "RRAAAR")                                              \
  X(kACrackles, "hfA_Crackles", "AARAA")                                         \
  X(kACircles, "hfA_Circles", "AAAA")                                            \
  X(kANoiseG, "hfA_NoiseG", "ARR")                                               \
  X(kANoiseP, "hfA_NoiseP", "A")                                                 \
  X(kATurbulence, "hfA_Turbulence", "AR")                                        \
  X(kASetColor, "hfA_SetColor", "RARRR")                                         \
  X(kASetAttributes, "hfA_SetAttributes", "RAA")                                 \
  X(kALerp, "hfA_Lerp", "AAARRR")                                                \
  X(kACerp, "hfA_Cerp", "AAARRR")                                                \
  X(kAClamp, "hfA_Clamp", "RRR")                                                 \
  X(kAFloor, "hfA_Floor", "R")                                                   \
  X(kAPulse, "hfA_Pulse", "RRR")                                                 \
  X(kALookUpTable, "hfA_LookUpTable", "RAAA")                                    \
  X(kASmoothLookUpTable, "hfA_SmoothLookUpTable", "RAAA")                        \
  X(kAStep, "hfA_Step", "RR")                                                    \
  X(kASmoothStep, "hfA_SmoothStep", "RRRRRR")                                    \
  X(kAModulo, "hfA_Modulo", "RR")                                                \
  X(kASpline, "hfA_Spline", "AARRR")                                             \
  X(kARGBToHSV, "hfA_RGBToHSV", "AA")                                            \
  X(kAHSVToRGB, "hfA_HSVToRGB", "AA")                                            \
  X(kDConeX, "hfDConeX", "AAR")                                                  \
  X(kDConeY, "hfDConeY", "AAR")                                                  \
  X(kDConeZ, "hfDConeZ", "AAR")                                                  \
  X(kDCylinder, "hfDCylinder", "AAAR")                                           \
  X(kDEllipsoid, "hfDEllipsoid", "AARRR")                                        \
  X(kDTorusX, "hfDTorusX", "AARR")                                               \
  X(kDTorusY, "hfDTorusY", "AARR")                                               \
  X(kDTorusZ, "hfDTorusZ", "AARR")                                               \
  X(kDUni, "hfDUni", "RRRR")                                                     \
  X(kDInt, "hfDInt", "RRRR")                                                     \
  X(kDSub, "hfDSub", "RRRR")                                                     \
  X(kDBlendUni, "hfDBlendUni", "RRR")                                            \
  X(kDBlendInt, "hfDBlendInt", "RRR")                                            \
  X(kSawtooth, "hfSawtooth", "RRRR")                                             \
  /* hfrt extensions (issue 10, docs/meshes.md): mesh and Bezier patch leaves */ \
  X(kMesh, "hfMesh", "AF")                                                       \
  X(kTriangles, "hfTriangles", "AAA")                                            \
  X(kBezierSurface, "hfBezierSurface", "AF")                                     \
  X(kBezierPatches, "hfBezierPatches", "AA")

enum class LibraryFn {
#define HFRT_X(e, s, k) e,
  HFRT_LIBRARY(HFRT_X)
#undef HFRT_X
};

/// Number of registered library functions.
inline constexpr int kLibraryFnCount = 0
#define HFRT_X(e, s, k) +1
    HFRT_LIBRARY(HFRT_X)
#undef HFRT_X
    ;

/// The library function with this name, compared case-insensitively.
std::optional<LibraryFn> find_library_fn(std::string_view name);
/// The name as the original library spells it ("hfSphere").
std::string_view library_fn_name(LibraryFn f);
/// One 'A', 'R' or 'F' per argument.
std::string_view library_fn_kinds(LibraryFn f);
/// hfMesh, hfTriangles, hfBezierSurface, hfBezierPatches: the leaves whose field comes from a
/// geom::Surface (an hfrt extension, docs/meshes.md).
inline bool is_surface_leaf(LibraryFn f) {
  return f == LibraryFn::kMesh || f == LibraryFn::kTriangles || f == LibraryFn::kBezierSurface ||
         f == LibraryFn::kBezierPatches;
}

}  // namespace hfrt::lang
