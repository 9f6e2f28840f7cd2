#pragma once
// Fixture of the layer check (tests/layers/CMakeLists.txt): a header of lang/.
