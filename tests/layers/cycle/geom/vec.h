#pragma once
// Fixture of the layer check: geom/ includes base/ (allowed on its own).
#include "base/vec.h"
