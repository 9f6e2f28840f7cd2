#!/usr/bin/env bash
# Whole `hfrt mesh` processes at 512^3 (the corpus gyroid and the FRep-Designer-Bench blend, the
# boxes of mesh_vs_grid.py), variants alternating round by round: the mesher's own time, the
# file's writing (`--stats`), and the process's wall and kernel time (/usr/bin/time).
#
#   bench/mesher/mesh_process.sh [--build build] [--rounds 3] [--res 512] VARIANT...
#
# A VARIANT is LABEL or LABEL:ENV, ENV being space-separated NAME=VALUE settings for that run,
# e.g. 'before:HFRT_MODULE_DIR=/tmp/old/modules HFRT_MALLOC_HUGEPAGES=0' 'after:'.
# (HFRT_MODULE_DIR runs another build's command module under the same launcher.)
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
build="$root/build"
rounds=3
res=512
variants=()
while [ $# -gt 0 ]; do
  case "$1" in
    --build) build="$2"; shift 2 ;;
    --rounds) rounds="$2"; shift 2 ;;
    --res) res="$2"; shift 2 ;;
    *) variants+=("$1"); shift ;;
  esac
done
[ ${#variants[@]} -gt 0 ] || variants=("default:")
bench="$root/../shared/corpus/models/github/alexander-penev__FRep-Designer-Bench"
models=("s4_gyroid -1.5,-1.5,-1.5,1.5,1.5,1.5" "s3_blend -1.25,-0.8,-0.8,1.25,0.8,0.8")
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
printf '%-12s %-10s %8s %9s %8s %8s\n' variant model "mesh s" "write ms" "wall s" "sys s"
for ((r = 0; r < rounds; ++r)); do
  for v in "${variants[@]}"; do
    label="${v%%:*}"
    envs=""
    [[ "$v" == *:* ]] && envs="${v#*:}"
    for m in "${models[@]}"; do
      read -r name box <<< "$m"
      # shellcheck disable=SC2086
      text=$({ /usr/bin/time -f 'time: wall %e sys %S' env $envs "$build/tools/hfrt/hfrt" mesh \
        "$bench/$name.hf" -o "$out/mesh.ply" --bbox "$box" --resolution "$res" --threads 2 \
        --stats; } 2>&1)
      mesh=$(sed -n 's/^stats: mesh \([0-9.]*\) s.*/\1/p' <<< "$text")
      write=$(sed -n 's/.*write \([0-9.]*\) ms.*/\1/p' <<< "$text")
      wall=$(sed -n 's/^time: wall \([0-9.]*\) .*/\1/p' <<< "$text")
      sys=$(sed -n 's/^time: .* sys \([0-9.]*\)/\1/p' <<< "$text")
      printf '%-12s %-10s %8s %9s %8s %8s\n' "$label" "$name" "$mesh" "$write" "$wall" "$sys"
    done
  done
done
