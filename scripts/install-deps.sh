#!/usr/bin/env bash
# Installs the Debian packages hfrt needs to build and test. Idempotent and quiet when
# everything is present; never prompts (CI runs it with no standard input).
# Usage: scripts/install-deps.sh [--bench | --fuzz]   (--bench adds the optional benchmark peers,
# --fuzz clang-19 and its runtime for `make fuzz`; `make test` needs neither)
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config
  python3  # scripts/check-layers.py (a test of make test)
  povray   # the independent reference of the `hfrt emit --pov` and example silhouette tests
  llvm-19-dev
  libcli11-dev
  libopenimageio-dev openimageio-tools libopencv-core-dev
  libgtest-dev libgmock-dev
  libboost-dev
  libtbb-dev
  libedit-dev
  libbenchmark-dev
  libassimp-dev
  zlib1g-dev libzstd-dev                                # zlib: the PNG writer (render/png_writer.cpp)
  libtomlplusplus-dev                                   # scene files (render/scene)
  pybind11-dev python3-dev python3-numpy python3-pytest  # the Python module, its tests, the numpy ray-cast reference
  python3-skimage                                       # the marching-cubes peer of the mesher tests/bench
  libopenmpi-dev openmpi-bin                            # rendering across processes (cluster/, mpirun tests)
  ffmpeg                                                # `hfrt render --video` and its test
  time                                                  # /usr/bin/time: peak memory in bench/startup/startup.py
)
if [[ "${1:-}" == "--bench" ]]; then
  packages+=(libembree-dev)   # optional: hfrt_bench_mesh compares against Embree when found
fi
if [[ "${1:-}" == "--fuzz" ]]; then
  packages+=(clang-19 libclang-rt-19-dev)   # `make fuzz` (libFuzzer) and the fuzz preset
fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
[[ ${#missing[@]} -eq 0 ]] && exit 0

echo "install-deps: installing ${missing[*]}" >&2
SUDO=""
if [[ $(id -u) -ne 0 ]]; then
  SUDO="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
