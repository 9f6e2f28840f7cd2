#pragma once
// render/'s vector vocabulary: the base Vec3 and Box (base/vec.h, base/box.h).

#include "base/box.h"
#include "base/vec.h"

namespace hfrt::render {

using ::hfrt::Box;
using ::hfrt::Vec3;

}  // namespace hfrt::render
