#pragma once
// The interface between geom/mesh.cpp and the mesh import module (libhfrt_meshimport.so,
// geom/mesh_import_assimp.cpp), which alone links Assimp. The module is loaded when a model first
// reads a mesh file (base/module.h), so that a process that never does, `hfrt check` above all,
// does not load Assimp and its libraries at start-up (issue 25).
//
// Both sides are built from one tree by one compiler, so the entry table passes C++ types; the
// ABI number guards against a module left over from another build.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "geom/vec.h"

namespace hfrt::geom::mesh_import {

inline constexpr int kAbiVersion = 1;
/// The entry point the module exports (extern "C", returns `const Module*`).
inline constexpr const char* kEntrySymbol = "hfrt_mesh_import_module";

/// What Assimp made of a file: polygons triangulated, points and lines dropped, every node's
/// transform applied, the meshes joined.
struct Imported {
  /// The counts of the whole file, set even when it is over the limit (and then nothing else).
  uint64_t num_vertices = 0, num_faces = 0;
  bool over_limit = false;
  std::vector<Vec3> vertices;
  std::vector<std::array<uint32_t, 3>> triangles;  ///< zero-based; faces of 3 corners only
};

/// The module's table. The function is thread-safe and never throws.
struct Module {
  int abi_version;
  /// Reads `size` bytes of a file in `format` (the extension without the dot: "off", "obj",
  /// "ply", "stl"). Files with more than `max_elements` vertices or faces stop after counting.
  /// False with `*error` (Assimp's text) when Assimp cannot read the file.
  bool (*import)(const char* data, size_t size, const char* format, uint64_t max_elements,
                 Imported* out, std::string* error);
};

}  // namespace hfrt::geom::mesh_import
