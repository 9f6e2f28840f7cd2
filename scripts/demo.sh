#!/usr/bin/env bash
# The main job on the default example. Until the renderer lands this checks every example
# and writes a 2-D picture of the default model's z = 0 slice.
set -euo pipefail
build=${1:-build}
"$build/tools/hfrt/hfrt" check examples/*.hf
if "$build/tools/hfrt/hfrt" render --help >/dev/null 2>&1; then
  "$build/tools/hfrt/hfrt" render examples/default.hf -o out/demo.png
  echo "demo: wrote out/demo.png"
fi
