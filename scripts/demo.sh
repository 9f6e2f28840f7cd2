#!/usr/bin/env bash
# The main job on the default example: check every example, then ray trace
# examples/default.hf with the default camera (framed three-quarter view), lights and root
# search to out/demo.png.
set -euo pipefail
build=${1:-build}
"$build/tools/hfrt/hfrt" check examples/*.hf
mkdir -p out
"$build/tools/hfrt/hfrt" render examples/default.hf -o out/demo.png
echo "demo: wrote out/demo.png"
