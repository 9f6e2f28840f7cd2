#!/usr/bin/env bash
# Render times of .hf scenes at 512x512 with `hfrt render --stats`, for several root-search
# methods in one run, with the split of thread time between per-tile interval culling, per-ray
# root search and shading. A timed CLI benchmark (the figures are hfrt's own render timer: the
# compile, framing and image writing are reported separately and not included).
#
#   bench/render_scenes.sh [--hfrt PATH] [--size WxH] [--roots sign,interval,auto] [--repeat N]
#                          [--timeout SECONDS] [SCENES_FILE]
#
# SCENES_FILE has one scene per line: `name|model path (relative to the repository)|extra
# hfrt render arguments`; '#' starts a comment. Default: bench/render_scenes.txt.
# Each (scene, root) pair is rendered --repeat times (default 3); the table shows the fastest.
# A render that runs past --timeout seconds (default 120) is shown as `TIMEOUT: >SECONDS s`.
set -euo pipefail

root_dir="$(cd "$(dirname "$0")/.." && pwd)"
hfrt="$root_dir/build/tools/hfrt/hfrt"
size=512x512
roots=sign,interval,auto
repeat=3
limit=120
scenes="$root_dir/bench/render_scenes.txt"
while [[ $# -gt 0 ]]; do
  case "$1" in
    --hfrt) hfrt="$2"; shift 2 ;;
    --size) size="$2"; shift 2 ;;
    --roots) roots="$2"; shift 2 ;;
    --repeat) repeat="$2"; shift 2 ;;
    --timeout) limit="$2"; shift 2 ;;
    -h|--help) sed -n '2,14p' "$0"; exit 0 ;;
    *) scenes="$1"; shift ;;
  esac
done
[[ -x "$hfrt" ]] || { echo "render_scenes: no hfrt at $hfrt (build first: make -C $root_dir test)" >&2; exit 2; }
[[ -f "$scenes" ]] || { echo "render_scenes: no scenes file $scenes" >&2; exit 2; }

tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

echo "# hfrt render at $size on $(nproc) cores ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')), $(date -u +%F)"
printf '%-14s %-9s %9s %8s %9s %9s %9s %12s %s\n' scene root render_s Mrays/s cull_s search_s shade_s tiles_empty used
IFS=',' read -ra root_list <<< "$roots"
while IFS='|' read -r name model extra; do
  [[ -z "$name" || "$name" == \#* ]] && continue
  for root in "${root_list[@]}"; do
    best=""
    for ((i = 0; i < repeat; ++i)); do
      # shellcheck disable=SC2086
      status=0
      timeout "$limit" "$hfrt" render "$root_dir/$model" -o "$tmp/out.png" --size "$size" \
        --root "$root" --stats $extra 2> "$tmp/err" || status=$?
      if [[ $status -eq 124 ]]; then
        best="TIMEOUT: >${limit} s"
        break
      elif [[ $status -ne 0 ]]; then
        best="FAILED: $(head -1 "$tmp/err")"
        break
      fi
      secs=$(sed -n 's/.*render \([0-9.]*\) s on.*/\1/p' "$tmp/err")
      if [[ -z "$best" ]] || awk -v a="$secs" -v b="$best" 'BEGIN{exit !(a<b)}'; then
        best="$secs"
        cp "$tmp/err" "$tmp/best"
      fi
    done
    if [[ "$best" == FAILED* || "$best" == TIMEOUT* ]]; then
      printf '%-14s %-9s %s\n' "$name" "$root" "$best"
      continue
    fi
    mrays=$(sed -n 's/.* rays, \([0-9.]*\) Mrays\/s.*/\1/p' "$tmp/best")
    cull=$(sed -n 's/.*culling \([0-9.]*\) s.*/\1/p' "$tmp/best")
    search=$(sed -n 's/.*root search \([0-9.]*\) s.*/\1/p' "$tmp/best")
    shade=$(sed -n 's/.*shading \([0-9.]*\) s.*/\1/p' "$tmp/best")
    empty=$(sed -n 's/.*tiles \([0-9]*\) (\([0-9]*\) empty.*/\2\/\1/p' "$tmp/best")
    used=$(sed -n 's/.*root search \([a-z]*\).*/\1/p' "$tmp/best" | head -1)
    printf '%-14s %-9s %9s %8s %9s %9s %9s %12s %s\n' "$name" "$root" "$best" "$mrays" "$cull" \
      "$search" "$shade" "${empty:--}" "$used"
  done
done < "$scenes"
