// The mesh import module (libhfrt_meshimport.so): the only code of geom/ that sees Assimp.
// geom/mesh_import_module.h says why it is a module and what the table means; geom/mesh.cpp
// checks a text file line by line before it gets here.

#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <assimp/Importer.hpp>

#include "geom/mesh_import_module.h"

namespace hfrt::geom::mesh_import {
namespace {

bool import(const char* data, size_t size, const char* format, uint64_t max_elements, Imported* out,
            std::string* error) {
  Assimp::Importer importer;
  // Points and lines are removed so that only polygons (triangulated) remain. The scene is
  // validated (every index in range) before any other step: the post-processing steps index
  // vertices unchecked and crash on a file whose faces name vertices it does not have.
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE,
                              aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  const aiScene* scene = importer.ReadFileFromMemory(
      data, size,
      aiProcess_ValidateDataStructure | aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
          aiProcess_PreTransformVertices | aiProcess_SortByPType,
      format);
  if (!scene) {
    *error = importer.GetErrorString();
    return false;
  }
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    out->num_vertices += scene->mMeshes[m]->mNumVertices;
    out->num_faces += scene->mMeshes[m]->mNumFaces;
  }
  if (out->num_faces > max_elements || out->num_vertices > max_elements) {
    out->over_limit = true;
    return true;
  }
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* am = scene->mMeshes[m];
    const uint32_t base = static_cast<uint32_t>(out->vertices.size());
    for (unsigned i = 0; i < am->mNumVertices; ++i) {
      const aiVector3D& v = am->mVertices[i];
      out->vertices.push_back({v.x, v.y, v.z});
    }
    for (unsigned f = 0; f < am->mNumFaces; ++f) {
      const aiFace& face = am->mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines: not part of a surface
      out->triangles.push_back(
          {base + face.mIndices[0], base + face.mIndices[1], base + face.mIndices[2]});
    }
  }
  return true;
}

const Module kModule{kAbiVersion, &import};

}  // namespace
}  // namespace hfrt::geom::mesh_import

extern "C" __attribute__((visibility("default"))) const hfrt::geom::mesh_import::Module*
hfrt_mesh_import_module() {
  return &hfrt::geom::mesh_import::kModule;
}
