#!/usr/bin/env bash
# The main job on the default example: check every example, then ray trace
# examples/default.hf with the default camera (framed three-quarter view), lights and root
# search to out/demo.png; then check the example scenes and trace one to out/demo_scene.png.
set -euo pipefail
build=${1:-build}
"$build/tools/hfrt/hfrt" check examples/*.hf
mkdir -p out
"$build/tools/hfrt/hfrt" render examples/default.hf -o out/demo.png
echo "demo: wrote out/demo.png"
# And one scene file (docs/scenes.md): a glass blob over a mirror floor, traced recursively,
# at a quarter of its size and one sample per pixel so that the demo stays quick.
"$build/tools/hfrt/hfrt" check examples/scenes/*.toml
"$build/tools/hfrt/hfrt" render examples/scenes/glass_blob_mirror.toml -o out/demo_scene.png \
  --size 320x240 --spp 1
echo "demo: wrote out/demo_scene.png"
