#pragma once
// Writing a mesher::TriMesh to a file through Assimp's exporter: STL (binary), OBJ, PLY
// (binary) and glTF binary (.glb), chosen by the file's extension. PLY and OBJ carry the
// per-vertex colours when the mesh has them (OBJ as the common `v x y z r g b` extension).

#include <optional>
#include <string>

#include "base/result.h"
#include "mesher/mesher.h"

namespace hfrt::mesher {

/// The Assimp exporter id for `path`'s extension (case-insensitive): "stlb" for .stl, "obj"
/// ... ; nullopt for an extension the mesher cannot write. For checking options before meshing.
std::optional<std::string> mesh_format_for(const std::string& path);

/// The extensions mesh_format_for accepts, for messages: ".stl, .obj, .ply or .glb".
const char* mesh_formats_list();

/// Writes `mesh` to `path` in the format of its extension. Returns the size of the file in
/// bytes, or an Error (environment: the file cannot be created or written; an unknown
/// extension) whose message starts with the path.
Result<size_t> write_mesh(const std::string& path, const TriMesh& mesh);

}  // namespace hfrt::mesher
