#!/usr/bin/env bash
# The interval and gradient JITs compiled in the background (docs/architecture.md, "Interval
# code compiled in the background"): for each build given, a cold render (`hfrt --no-cache
# render --stats`, 512x512, the machine's threads) of models of 255 to 1241 IR instructions
# (MODELS="a.hf b.hf" for other models): the wait before
# the render starts (the "compile" figure and the "+ ... interval and gradient code" that
# prepare_render_code waited for), the render itself and the whole process (wall and user
# CPU). Builds alternate per model and round, so a drifting machine affects both alike.
#   bench/jit/background_interval.sh build [other-build ...]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(dirname "$(dirname "$here")")
corpus=$root/../shared/corpus
[ $# -ge 1 ] || { echo "usage: $0 BUILD [BUILD ...]" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# 72 and 90 spheres joined by max: 993 and 1241 IR instructions of plain arithmetic.
for count in 72 90; do
python3 - "$tmp/spheres$count.hf" "$count" <<'PY'
import random, sys
random.seed(3)
lines = ["my_model(x[3], a[1]) {"]
acc = None
for i in range(int(sys.argv[2])):
    cx, cy, cz = [round(random.uniform(-2, 2), 3) for _ in range(3)]
    r = round(random.uniform(0.2, 0.6), 3)
    lines.append(f"  dx{i} = x[1]-({cx}); dy{i} = x[2]-({cy}); dz{i} = x[3]-({cz});")
    lines.append(f"  s{i} = {r*r:.4f} - dx{i}*dx{i} - dy{i}*dy{i} - dz{i}*dz{i};")
    if acc is None:
        acc = f"s{i}"
    else:
        lines.append(f"  u{i} = max({acc}, s{i});")
        acc = f"u{i}"
lines += [f"  my_model = {acc};", "}"]
open(sys.argv[1], "w").write("\n".join(lines) + "\n")
PY
done
# Prospero's first 536 lines (a 2-D model: 551 IR instructions), its last min as the value.
p=$corpus/bench/prospero.hf
{ head -536 "$p"; echo "  my_model = -$(sed -n 536p "$p" | sed 's/ *\([a-z0-9]*\) =.*/\1/');"; echo "}"; } \
  > "$tmp/prospero536.hf"
models=${MODELS:-"$corpus/models/github/alexander-penev__FRep-Designer-Bench/c1_gear.hf $tmp/prospero536.hf $tmp/spheres72.hf $tmp/spheres90.hf"}
for m in $models; do
  for round in 1 2; do
    for b in "$@"; do
      out=$( { /usr/bin/time -f "process %e s wall, %U s user" "$b/tools/hfrt/hfrt" --no-cache \
        render "$m" -o "$tmp/x.png" --size 512x512 --stats; } 2>&1 |
        grep -E "^stats: compile|render [0-9.]+ s|^process" |
        sed -E 's/^stats: //; s/framing .*auto probe [0-9.]+ ms, //' | tr '\n' ' ')
      printf '%-16s %-22s %s\n' "$(basename "$m" .hf)" "$b" "$out"
    done
  done
done
