// Fuzz target: the Bezier patch reader (geom::parse_bpt). Any bytes; a patch set that parses
// has degrees in 1..3 and finite control points, and must survive tessellation, the
// PatchSurface build and every surface query.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "base/check.h"
#include "fuzz/geom_queries.h"
#include "geom/bezier.h"
#include "geom/patch_surface.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace hfrt;
  Result<geom::PatchSet> set =
      geom::parse_bpt(std::string(reinterpret_cast<const char*>(data), size), "fuzz.bpt");
  if (!set) return 0;
  HFRT_CHECK(!set->patches.empty());
  for (const geom::BezierPatch& p : set->patches) {
    HFRT_CHECK(p.du >= 1 && p.du <= 3 && p.dv >= 1 && p.dv <= 3);
    for (int k = 0; k < (p.du + 1) * (p.dv + 1); ++k) {
      HFRT_CHECK(std::isfinite(p.cp[k].x) && std::isfinite(p.cp[k].y) && std::isfinite(p.cp[k].z));
    }
  }
  if (set->patches.size() > 64) return 0;  // queries cost; parsing is the point
  float max_error = 0;
  (void)geom::tessellate(*set, 4, &max_error);
  auto surface = geom::PatchSurface::build(*set);
  fuzz::exercise_surface(*surface);
  return 0;
}
