#pragma once
// Fixture of the layer check: base/ includes geom/ (an arrow up, and a cycle with geom/vec.h).
#include "geom/vec.h"
