#!/usr/bin/env bash
# The device check of hfrt's CUDA back end, in two halves (docs/gpu.md, "Running the device
# check"):
#
#   scripts/gpu-check.sh prepare BUILD_DIR OUT_DIR
#       on the build machine: writes the check cases (BUILD_DIR/tools/hfrt/hfrt gpu-cases
#       OUT_DIR/cases) and copies BUILD_DIR/tools/gpu_runner/hfrt_gpu_runner to OUT_DIR.
#   scripts/gpu-check.sh run DIR [RESULTS_DIR]
#       on the GPU machine: prints nvidia-smi (if present), runs DIR/hfrt_gpu_runner over
#       DIR/cases with a time limit (280 s), and keeps what it printed in
#       RESULTS_DIR/gpu-check.txt and the rendered images in RESULTS_DIR. RESULTS_DIR defaults
#       to $OUT if set, else DIR/results.
#
# Exit status: the runner's (0 all cases ran, 1 a case failed or no driver or device, 124 the
# time limit), 2 on usage errors.
set -u

usage() {
  echo "usage: $0 prepare BUILD_DIR OUT_DIR" >&2
  echo "       $0 run DIR [RESULTS_DIR]" >&2
  exit 2
}

cmd="${1:-}"
case "$cmd" in
  prepare)
    [ $# -eq 3 ] || usage
    build="$2"
    out="$3"
    hfrt="$build/tools/hfrt/hfrt"
    runner="$build/tools/gpu_runner/hfrt_gpu_runner"
    for f in "$hfrt" "$runner"; do
      if [ ! -x "$f" ]; then
        echo "gpu-check: $f is missing (build the targets hfrt and hfrt_gpu_runner)" >&2
        exit 1
      fi
    done
    mkdir -p "$out" || exit 1
    # The corpus beside this checkout (hfrt gpu-cases reads HFRT_CORPUS_DIR).
    if [ -z "${HFRT_CORPUS_DIR:-}" ]; then
      HFRT_CORPUS_DIR="$(cd "$(dirname "$0")/.." && pwd)/../shared/corpus"
      export HFRT_CORPUS_DIR
    fi
    "$hfrt" gpu-cases "$out/cases" || {
      echo "gpu-check: $hfrt gpu-cases $out/cases failed" >&2
      exit 1
    }
    cp "$runner" "$out/" || exit 1
    echo "gpu-check: prepared $out (run: scripts/gpu-check.sh run $out)"
    ;;
  run)
    [ $# -eq 2 ] || [ $# -eq 3 ] || usage
    dir="$2"
    results="${3:-${OUT:-$dir/results}}"
    if [ ! -x "$dir/hfrt_gpu_runner" ] || [ ! -d "$dir/cases" ]; then
      echo "gpu-check: $dir has no hfrt_gpu_runner or no cases/ (run: scripts/gpu-check.sh prepare BUILD_DIR $dir)" >&2
      exit 1
    fi
    mkdir -p "$results" || exit 1
    {
      if command -v nvidia-smi > /dev/null 2>&1; then
        timeout 30 nvidia-smi
      else
        echo "gpu-check: no nvidia-smi on this machine"
      fi
      timeout 280 "$dir/hfrt_gpu_runner" "$dir/cases" --out "$results"
      status=$?
      [ $status -eq 124 ] && echo "gpu-check: hfrt_gpu_runner stopped after 280 s"
      echo "gpu-check: exit status $status"
      exit $status
    } 2>&1 | tee "$results/gpu-check.txt"
    exit "${PIPESTATUS[0]}"
    ;;
  *)
    usage
    ;;
esac
