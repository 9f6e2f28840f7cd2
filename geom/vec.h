#pragma once
// geom/'s vector vocabulary: the base Vec3 and Box (base/vec.h, base/box.h) and the ray of
// the mesh and patch intersectors.

#include "base/box.h"
#include "base/vec.h"

namespace hfrt::geom {

using ::hfrt::Box;
using ::hfrt::Vec3;

/// A ray org + t dir. `dir` need not be unit length: t is measured in units of |dir|.
struct Ray {
  Vec3 org, dir;
};

}  // namespace hfrt::geom
