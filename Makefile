# The two set-up commands of README.md. Both install missing Debian packages first.
BUILD_DIR ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?= -G Ninja -DCMAKE_BUILD_TYPE=Release

.PHONY: all deps configure build demo test bench bench-render bench-peers bench-meshes bench-mesh bench-scenes bench-cluster bench-startup clean format package
.PHONY: test-asan test-tsan fuzz

all: build

deps:
	@scripts/install-deps.sh

configure: deps
	@if [ ! -f $(BUILD_DIR)/build.ninja ]; then cmake -S . -B $(BUILD_DIR) $(CMAKE_FLAGS); fi

build: configure
	@cmake --build $(BUILD_DIR) -j $(JOBS)

demo: build
	@mkdir -p out
	@scripts/demo.sh $(BUILD_DIR)

test: build
	@cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS) --timeout 600

bench: build
	@cmake --build $(BUILD_DIR) --target hfrt_bench -j $(JOBS)

# Render times of .hf scenes (bench/render_scenes.txt) at 512x512, by root-search method.
bench-render: build
	@bench/render_scenes.sh --hfrt $(BUILD_DIR)/tools/hfrt/hfrt

# hfrt vs POV-Ray 3.7 on the same scenes (installs povray), then prospero's distance to the
# machine's peak (bench/README.md). PEERS_ARGS: e.g. --size 256 --scenes csg,blend.
PEERS_ARGS ?= --repeat 2
bench-peers: configure
	@scripts/install-deps.sh --bench
	@cmake --build $(BUILD_DIR) --target hfrt hfrt_bench_maskdiff hfrt_bench_prospero -j $(JOBS)
	@bench/peers/povray --build-dir $(BUILD_DIR) $(PEERS_ARGS)
	@$(BUILD_DIR)/bench/hfrt_bench_prospero --frames 3 --interp-rows 4

# hfrt vs POV-Ray 3.7 on the teapot (bicubic_patch) and the armadillo (mesh2), then the ray
# rates against Embree (installs povray and libembree-dev; bench/README.md). MESHES_ARGS: e.g.
# --size 256 --repeat 5.
MESHES_ARGS ?= --repeat 3
bench-meshes: configure
	@scripts/install-deps.sh --bench
	@cmake -S . -B $(BUILD_DIR) > /dev/null
	@cmake --build $(BUILD_DIR) --target hfrt hfrt_bench_maskdiff hfrt_bench_mesh -j $(JOBS)
	@bench/peers/povray_meshes --build-dir $(BUILD_DIR) $(MESHES_ARGS)
	@$(BUILD_DIR)/bench/hfrt_bench_mesh --frames 5

# hfrt mesh vs scikit-image marching cubes on a JIT-sampled grid (bench/README.md).
# MESH_ARGS: e.g. --res 256 --models gyroid,blend,csg --threads 2.
MESH_ARGS ?=
bench-mesh: build
	@cmake --build $(BUILD_DIR) --target hfrt hfrt_bench_mesh_tool -j $(JOBS)
	@/usr/bin/python3 bench/mesher/mesh_vs_grid.py --build $(BUILD_DIR) $(MESH_ARGS)

# hfrt vs POV-Ray 3.7 on the scene files of examples/scenes (reflection, refraction, area
# lights, depth of field): wall times side by side, the max-depth-0 cost, images side by side
# in out/bench-scenes. SCENES_ARGS: e.g. --size 320x240 --spp 1 --threads 2.
SCENES_ARGS ?= --size 320x240 --spp 1
bench-scenes: build
	@/usr/bin/python3 bench/peers/povray_scenes --build-dir $(BUILD_DIR) $(SCENES_ARGS)

# MPI scaling of `hfrt render` (1 process, then mpirun -np 2): one image by tiles, a sequence by
# frames, bit-identity checked, and an estimate for 64 ranks. CLUSTER_ARGS: e.g. --ranks 2,3.
CLUSTER_ARGS ?=
bench-cluster: build
	@/usr/bin/python3 bench/cluster/mpi_scaling.py --build $(BUILD_DIR) $(CLUSTER_ARGS)

# Start-up cost of hfrt commands (issue 25): CPU, peak memory and shared objects per process.
# STARTUP_ARGS: e.g. --runs 20 --hfrt /usr/bin/hfrt (compare with another build).
STARTUP_ARGS ?=
bench-startup: build
	@/usr/bin/python3 bench/startup/startup.py --hfrt $(BUILD_DIR)/tools/hfrt/hfrt $(STARTUP_ARGS)

clean:
	@rm -rf $(BUILD_DIR) out

format:
	@git ls-files '*.cpp' '*.h' | xargs clang-format -i

# The Debian package (CPack, cmake/HfrtPackage.cmake): $(BUILD_DIR)/hfrt_VERSION_amd64.deb.
# Install it with `sudo apt-get install ./$(BUILD_DIR)/hfrt_*.deb`.
package: build
	@cd $(BUILD_DIR) && cpack -G DEB

# The suite under sanitizers (CMakePresets.json: `asan` = ASan + UBSan in build-asan, `tsan` in
# build-tsan). LLVM's own allocations and the JIT'd code are not instrumented; what is
# suppressed, and why, is in scripts/sanitizers/. SAN_TARGETS: what to build (default all);
# SAN_CTEST_ARGS: which tests; by default all but those that load libhfrt.so into a program
# built without the sanitizer (the Python module in /usr/bin/python3, the installed-package
# consumers), which the sanitizer runtimes cannot start in.
SAN_TARGETS ?= all
SAN_CTEST_ARGS ?= -E '^(python\.|capi\.install_consumers)'
SAN_DIR := $(CURDIR)/scripts/sanitizers
ASAN_ENV = ASAN_OPTIONS=detect_leaks=1:check_initialization_order=1:abort_on_error=0 \
  LSAN_OPTIONS=suppressions=$(SAN_DIR)/lsan.supp:print_suppressions=0 \
  UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1:suppressions=$(SAN_DIR)/ubsan.supp
TSAN_ENV = TSAN_OPTIONS=halt_on_error=1:second_deadlock_stack=1:suppressions=$(SAN_DIR)/tsan.supp

test-asan: deps
	@if [ ! -f build-asan/build.ninja ]; then cmake --preset asan; fi
	@cmake --build build-asan -j $(JOBS) --target $(SAN_TARGETS)
	@cd build-asan && $(ASAN_ENV) ctest --output-on-failure -j $(JOBS) --timeout 1800 $(SAN_CTEST_ARGS)

test-tsan: deps
	@if [ ! -f build-tsan/build.ninja ]; then cmake --preset tsan; fi
	@cmake --build build-tsan -j $(JOBS) --target $(SAN_TARGETS)
	@cd build-tsan && $(TSAN_ENV) ctest --output-on-failure -j $(JOBS) --timeout 1800 $(SAN_CTEST_ARGS)

# libFuzzer targets (fuzz/, the `fuzz` preset: clang-19, build-fuzz), each run FUZZ_SECONDS on
# seed corpora from ../shared/corpus; prints exec/s and coverage per target (scripts/fuzz.sh).
FUZZ_SECONDS ?= 60
fuzz: deps
	@scripts/install-deps.sh --fuzz
	@FUZZ_JOBS=$(JOBS) scripts/fuzz.sh $(FUZZ_SECONDS)
