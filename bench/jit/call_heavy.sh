#!/usr/bin/env bash
# Call-heavy models (docs/architecture.md, "Call-heavy point and gradient code"): for each
# build given, the scalar JIT's compile without the cache (`hfrt eval --stats`: lanes, calls,
# optimise and codegen times) and the evaluation speed with a warm cache (`hfrt slice
# --no-prune`, 256x256, one thread: the f32 JIT at every pixel), on the corpus's historical
# FRep-Designer-Bench models, whose `^`, atan2 and exp are libm calls lane by lane. Builds
# alternate per model, so a drifting machine affects both alike.
#   bench/jit/call_heavy.sh build [other-build ...]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$(dirname "$here")")
models=$root/../shared/corpus/models/github/alexander-penev__FRep-Designer-Bench/historical_ec6a149
[ $# -ge 1 ] || { echo "usage: $0 BUILD [BUILD ...]" >&2; exit 2; }
cache=$(mktemp -d)
trap 'rm -rf "$cache"' EXIT
for m in hello_world architecture involute_gear_3d prospero; do
  for b in "$@"; do
    hfrt=$b/tools/hfrt/hfrt
    jit=$(echo "0.1 0.2 0.3" | "$hfrt" --no-cache eval "$models/$m.hf" --stats 2>&1 |
          grep "jit f64" | sed 's/^stats: //')
    c="$cache/$(echo "$b" | tr / _)"
    HFRT_CACHE_DIR=$c "$hfrt" slice "$models/$m.hf" -o "$cache/s.png" --bbox -4,-4,4,4 \
      --size 256x256 --no-prune --threads 1 > /dev/null 2>&1 || true  # fills the cache
    slice=$(HFRT_CACHE_DIR=$c "$hfrt" slice "$models/$m.hf" -o "$cache/s.png" --bbox -4,-4,4,4 \
      --size 256x256 --no-prune --threads 1 --stats 2>&1 | grep -oE "slice [0-9.]+ s" || true)
    printf '%-17s %-24s %s; warm %s\n' "$m" "$b" "$jit" "$slice"
  done
done
