// Every corpus model (and the examples with mesh and Bezier leaves) meshed through the app
// layer (app::run_mesh_job: the model's field, its extent, the mesher) at a modest resolution:
// the mesh must be closed, manifold and oriented outward (positive volume), whatever the
// model computes (while loops, arrays, NaN regions, library primitives, blends).

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "app/mesh_job.h"
#include "hfrt/model.h"
#include "tests/mesher/mesh_check.h"

namespace hfrt::mesher {
namespace {

struct Case {
  const char* path;  // relative to the corpus (or "examples/..." relative to the source)
  int resolution;
  std::vector<double> params = {};  // -a
  double simplify = 0;              // --simplify
};

std::string full_path(const std::string& p) {
  if (p.rfind("examples/", 0) == 0) return std::string(HFRT_SOURCE_DIR) + "/" + p;
  return std::string(HFRT_CORPUS_DIR) + "/models/" + p;
}

class CorpusMesh : public ::testing::TestWithParam<Case> {};

TEST_P(CorpusMesh, ClosedOrientedManifold) {
  const std::string path = full_path(GetParam().path);
  CompileResult compiled = Model::compile_file(path);
  ASSERT_TRUE(compiled.model) << compiled.rendered;
  if (!GetParam().params.empty()) compiled.model->set_params(GetParam().params);
  app::MeshJob job;
  job.model = &*compiled.model;
  job.file = path;
  job.resolution = GetParam().resolution;
  job.simplify = GetParam().simplify;
  app::MeshJobResult r = app::run_mesh_job(job);
  ASSERT_EQ(r.status, app::MeshJobStatus::kOk) << r.error;
  EXPECT_EQ(testing::check_closed_manifold(r.mesh.vertices, r.mesh.triangles), "");
  EXPECT_GT(testing::mesh_volume(r.mesh.vertices, r.mesh.triangles), 0);
  if (compiled.model->num_attributes() >= 3) {
    EXPECT_EQ(r.mesh.colors.size(), r.mesh.vertices.size());
  }
}

const Case kCases[] = {
    {"github/alexander-penev__FRep-Designer-Bench/s1_sphere.hf", 32},
    {"github/alexander-penev__FRep-Designer-Bench/s2_csg.hf", 40},
    {"github/alexander-penev__FRep-Designer-Bench/s3_blend.hf", 40},
    {"github/alexander-penev__FRep-Designer-Bench/s4_gyroid.hf", 48},
    {"github/alexander-penev__FRep-Designer-Bench/s5_twist.hf", 40},
    {"github/alexander-penev__FRep-Designer-Bench/c1_gear.hf", 64},
    {"github/alexander-penev__FRep-Designer-Bench/c2_colonnade.hf", 64},
    {"github/adda-team__adda/example.hf", 40},
    {"github/pmur002__hyperfun-report/csg.hf", 40},
    {"github/pmur002__hyperfun-report/sphere.hf", 24},
    {"web/frep_org__hf_objects__ColorSphere.hf", 32, {0.2, 0, 0, 1}},
    {"web/hfw_docs__torus_isosurface.hf", 40},
    {"web/hyperfun_org__gallery__infinity_yoshida.hf", 48},
    {"web/hyperfun_org__sample_model__superell_torus_soft.hf", 40},
    {"web/java_hyperfun_applet__HFMain_default_model.hf", 40},
    {"web/stat_auckland__NZSA2022__dice_assembled.hf", 48},
    {"examples/armadillo.hf", 40},
    {"examples/teapot.hf", 40},
    // Simplified: still closed, oriented manifolds.
    {"github/alexander-penev__FRep-Designer-Bench/c1_gear.hf", 48, {}, 1e-3},
    {"github/alexander-penev__FRep-Designer-Bench/s4_gyroid.hf", 40, {}, 2e-3},
};

// The corpus's block minus sphere is empty (the unit block fits inside the unit ball): a
// located error, not a mesh.
TEST(CorpusMeshErrors, EmptyModelHasNoSurface) {
  const std::string path = full_path("web/stat_auckland__NZSA2022__HF_27_1_block_minus_sphere.hf");
  CompileResult compiled = Model::compile_file(path);
  ASSERT_TRUE(compiled.model) << compiled.rendered;
  app::MeshJob job;
  job.model = &*compiled.model;
  job.file = "block_minus_sphere.hf";
  job.resolution = 32;
  app::MeshJobResult r = app::run_mesh_job(job);
  EXPECT_EQ(r.status, app::MeshJobStatus::kNoSurface);
  EXPECT_EQ(r.error.rfind(
                "block_minus_sphere.hf: error: object 'my_model' has no surface in the box ", 0),
            0u)
      << r.error;
  EXPECT_TRUE(r.mesh.triangles.empty());
}

INSTANTIATE_TEST_SUITE_P(Models, CorpusMesh, ::testing::ValuesIn(kCases),
                         [](const ::testing::TestParamInfo<Case>& info) {
                           std::string name = info.param.path;
                           name = name.substr(name.find_last_of('/') + 1);
                           name = name.substr(0, name.find('.'));
                           if (info.param.simplify > 0) name += "_simplified";
                           for (char& c : name)
                             if (!isalnum(static_cast<unsigned char>(c))) c = '_';
                           return name;
                         });

}  // namespace
}  // namespace hfrt::mesher
