#pragma once
// The interface between mesher/mesh_io.cpp and the mesh export module (libhfrt_meshexport.so,
// mesher/mesh_export_assimp.cpp), which alone links Assimp's exporters. It is loaded when a mesh
// is first written (base/module.h), so that other processes do not load Assimp at start-up
// (issue 25).
//
// Both sides are built from one tree by one compiler, so the entry table passes C++ types; the
// ABI number guards against a module left over from another build.

#include <string>

#include "mesher/mesher.h"

namespace hfrt::mesher::mesh_export {

inline constexpr int kAbiVersion = 1;
/// The entry point the module exports (extern "C", returns `const Module*`).
inline constexpr const char* kEntrySymbol = "hfrt_mesh_export_module";

/// The module's table. The function is thread-safe and never throws.
struct Module {
  int abi_version;
  /// Writes `mesh` (per-vertex colours when it has them) to `path` in Assimp's export format
  /// `format` ("stlb", "objnomtl", "plyb", "glb2"); false with `*error` (Assimp's text).
  bool (*write)(const std::string& path, const std::string& format, const TriMesh& mesh,
                std::string* error);
};

}  // namespace hfrt::mesher::mesh_export
