// Fixture of the layer check: render/ may include only base/, so this arrow goes up.
#include "lang/check.h"
