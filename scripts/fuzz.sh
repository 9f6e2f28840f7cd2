#!/usr/bin/env bash
# `make fuzz FUZZ_SECONDS=N`: builds the libFuzzer targets of fuzz/ in build-fuzz/ (cmake
# --preset fuzz: clang-19, ASan + UBSan) and runs each for N seconds on a scratch corpus seeded
# from ../shared/corpus (HyperFun files for the front end, lowering and differential targets;
# mesh and patch files for the loaders), fuzz/seeds/ and examples/scenes/*.toml (the scene
# reader). Prints, per target, the executions per second and the coverage (edges, `cov:`) of
# libFuzzer's last status line. Exits 1 when a target found a crash or a mismatch; the
# reproducer is in build-fuzz/fuzz-work/crashes/<target>/ (run the target on it to replay).
#
# Usage: scripts/fuzz.sh [SECONDS]   Environment: FUZZ_TARGETS (default: all), FUZZ_JOBS,
#        HFRT_CORPUS_DIR (default ../shared/corpus), FUZZ_BUILD_DIR (default build-fuzz),
#        FUZZ_NO_BUILD=1 (run what is built).
set -euo pipefail

seconds=${1:-60}
root=$(cd "$(dirname "$0")/.." && pwd)
build=${FUZZ_BUILD_DIR:-$root/build-fuzz}
corpus=${HFRT_CORPUS_DIR:-$root/../shared/corpus}
targets=${FUZZ_TARGETS:-"frontend lower differential mesh bpt scene"}
jobs=${FUZZ_JOBS:-$(nproc)}
work=$build/fuzz-work

if [[ ! -f $build/build.ninja ]]; then
  launcher=()
  if command -v ccache >/dev/null; then
    launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
  fi
  cmake --preset fuzz -S "$root" -B "$build" "${launcher[@]}"
fi
names=()
for t in $targets; do names+=("hfrt_fuzz_$t"); done
[[ -n ${FUZZ_NO_BUILD:-} ]] || cmake --build "$build" -j "$jobs" --target "${names[@]}"

# seed DIR FILES...: copies the files into DIR (the scratch corpus keeps what earlier runs found).
seed() {
  local dir=$1
  shift
  mkdir -p "$dir"
  for f in "$@"; do [[ -f $f ]] && cp -f "$f" "$dir/seed_$(basename "$f")"; done
  return 0
}
# The mesh target reads the format from the first byte: 0 .off, 1 .ply, 2 .obj, 3 .stl. Large
# files are cut to their first 8 KiB (the target's -max_len).
seed_mesh() {
  local dir=$1 f byte
  shift
  mkdir -p "$dir"
  for f in "$@"; do
    [[ -f $f ]] || continue
    case "${f##*.}" in off) byte='\000' ;; ply) byte='\001' ;; obj) byte='\002' ;; stl) byte='\003' ;; *) continue ;; esac
    { printf "$byte"; head -c 8191 "$f"; } >"$dir/seed_$(basename "$f")"
  done
}

shopt -s nullglob globstar
hf_files=("$corpus"/parse/*.hf "$corpus"/models/**/*.hf "$root"/examples/*.hf)
for t in $targets; do
  dir=$work/corpus/$t
  case $t in
    frontend | lower) seed "$dir" "${hf_files[@]}" ;;
    # fuzz/seeds/differential: inputs that once failed (kept as regression seeds).
    differential) seed "$dir" "${hf_files[@]}" "$root"/fuzz/seeds/differential/* ;;
    mesh) seed_mesh "$dir" "$corpus"/meshes/* "$root"/fuzz/seeds/mesh/* ;;
    bpt) seed "$dir" "$corpus"/bezier/*.bpt "$root"/fuzz/seeds/bpt/* ;;
    scene) seed "$dir" "$root"/examples/scenes/*.toml ;;
  esac
done

export ASAN_OPTIONS=${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$root/scripts/sanitizers/lsan.supp:print_suppressions=0}
status=0
summary=()
for t in $targets; do
  mkdir -p "$work/crashes/$t"
  log=$work/$t.log
  echo "fuzz: hfrt_fuzz_$t for ${seconds}s (log: $log)" >&2
  max_len=4096
  [[ $t == mesh || $t == bpt ]] && max_len=8192
  rc=0
  (cd "$work" && "$build/fuzz/hfrt_fuzz_$t" -max_total_time="$seconds" -timeout=20 \
    -rss_limit_mb=4096 -max_len=$max_len -print_final_stats=1 \
    -artifact_prefix="$work/crashes/$t/" "$work/corpus/$t") >"$log" 2>&1 || rc=$?
  last=$(grep -E '^#[0-9]+.*cov:' "$log" | tail -n 1 || true)
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
  eps=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -n 1)
  cov=$(sed -n 's/.*cov: \([0-9]*\).*/\1/p' <<<"$last")
  verdict=ok
  if [[ $rc -ne 0 ]]; then
    verdict="FAILED (rc $rc; reproducer in $work/crashes/$t/)"
    status=1
  fi
  summary+=("$(printf '%-13s %4ss  runs %-9s exec/s %-7s cov %-6s %s' "$t" "$seconds" "${runs:-?}" "${eps:-?}" "${cov:-?}" "$verdict")")
  echo "  last status: ${last:-none}" >&2
done
echo "fuzz summary (${seconds}s per target):"
printf '  %s\n' "${summary[@]}"
exit $status
