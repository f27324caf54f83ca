# slamkit quick start: `make demo` and `make test`. Both install any missing Debian packages first
# (apt-get; sudo when not root), then configure and build in Release with all cores.

BUILD_DIR ?= build
JOBS ?= $(shell nproc)
DEMO_OUT ?= out/demo
SLAMKIT := $(BUILD_DIR)/slamkit

# Everything the build, the tests and the benchmarks need, all from Debian 12 (`time` is GNU time,
# for the peak memory of end-to-end runs; Python and Chromium for the Python module's tests and the
# replay page's browser test).
DEB_PACKAGES := cmake make g++ libeigen3-dev libgtest-dev libgmock-dev libbenchmark-dev \
                nlohmann-json3-dev libcli11-dev libfmt-dev zlib1g-dev libyaml-cpp-dev time
# What `make test` needs beyond that (the demo does without them).
TEST_DEB_PACKAGES := pybind11-dev python3-dev python3-numpy python3-pytest python3-matplotlib \
                     chromium chromium-driver libopenmpi-dev openmpi-bin
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)

.PHONY: all deps test-deps build demo test bench bench-e2e bench-compare clean sanitize fuzz soak readme-tables

all: build

# Installs the missing packages of the list given.
define install_missing
	@missing=""; \
	for p in $(1); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ]; then \
	  echo "Installing missing Debian packages:$$missing"; \
	  $(SUDO) apt-get update && \
	  $(SUDO) env DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends $$missing; \
	fi
endef

deps:
	$(call install_missing,$(DEB_PACKAGES))

test-deps: deps
	$(call install_missing,$(TEST_DEB_PACKAGES))

build: deps
	cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=Release
	cmake --build $(BUILD_DIR) -j $(JOBS)

# The main job on the built-in simulated world: simulate, run EKF-SLAM, evaluate, draw. Only the
# command line is built (not the tests, benchmarks or Python module), so the first result comes quickly.
demo: deps
	cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=Release
	cmake --build $(BUILD_DIR) -j $(JOBS) --target slamkit
	$(SLAMKIT) simulate --seed 1 --out $(DEMO_OUT)/sim
	$(SLAMKIT) run --filter ekf --data sim:$(DEMO_OUT)/sim --out $(DEMO_OUT)/ekf
	$(SLAMKIT) evaluate $(DEMO_OUT)/ekf

test: test-deps build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS)

# Micro-benchmarks (Google Benchmark, medians of 5 repetitions; the information filters' series
# alone took 7 minutes in one repetition, most of it driving their maps' routes), and whole runs of the
# command line. Neither is part of `make test`. docs/performance.md explains the figures.
# BENCH_ARGS passes Google Benchmark options, e.g. BENCH_ARGS=--benchmark_filter=Ekf.
BENCH_ARGS ?=
# The results go to out/bench/bench.json, and `slamkit plot-bench` draws them into out/bench/*.svg.
bench: build
	mkdir -p out/bench
	$(BUILD_DIR)/slamkit_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true \
	  --benchmark_out=out/bench/bench.json --benchmark_out_format=json $(BENCH_ARGS)
	$(SLAMKIT) plot-bench out/bench/bench.json --out out/bench

bench-e2e: build
	SLAMKIT=$(SLAMKIT) scripts/bench_end_to_end.sh

# slamkit's EKF next to MRPT's EKF-SLAM (CRangeBearingKFSLAM2D) on the same simulated logs. Optional:
# MRPT (Debian libmrpt-slam-dev) is installed here only, and neither the library nor `make test` uses
# it. The tool is a separate CMake project, tools/mrpt_compare, linking the built libslamkit.a.
bench-compare: build
	@dpkg-query -W -f='$${Status}' libmrpt-slam-dev 2>/dev/null | grep -q "install ok installed" || { \
	  echo "Installing libmrpt-slam-dev (for bench-compare only)"; \
	  $(SUDO) apt-get update && \
	  $(SUDO) env DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends libmrpt-slam-dev; }
	cmake -S tools/mrpt_compare -B $(BUILD_DIR)/mrpt_compare -DCMAKE_BUILD_TYPE=Release \
	  -DSLAMKIT_BUILD_DIR=$(abspath $(BUILD_DIR))
	cmake --build $(BUILD_DIR)/mrpt_compare -j $(JOBS)
	SLAMKIT=$(SLAMKIT) MRPT_TOOL=$(BUILD_DIR)/mrpt_compare/mrpt_ekf_slam scripts/bench_compare.sh

# ---- Reliability: clang with sanitizers, fuzzing, soak (.ci/run runs sanitize and fuzz) ----
# clang 14 and its runtimes (libFuzzer, AddressSanitizer, UndefinedBehaviorSanitizer).
CLANG_DEB_PACKAGES := clang-14 libclang-rt-14-dev
SANITIZE_BUILD_DIR ?= build-sanitize
# Seconds each fuzz target runs in `make fuzz`; new inputs and findings go to out/fuzz/<target>/.
FUZZ_SECONDS ?= 20
# One clang build serves both targets: the whole suite runs on it under AddressSanitizer (leaks
# included) and UndefinedBehaviorSanitizer, and the fuzz targets link the same library objects, which
# carry libFuzzer's coverage instrumentation (inert without libFuzzer). Every check aborts at its
# first finding; warnings are errors.
#
# UBSan's pointer-overflow and object-size checks are left out, and Eigen's asserts kept in their place
# (optimised, but no NDEBUG): the two checks instrument every index Eigen computes and stop the
# inliner, which made the sanitized suite take 24 minutes instead of 10, while AddressSanitizer and
# Eigen's range asserts catch the accesses they would (docs/testing.md has the measurements).
SANITIZE_FLAGS := -fsanitize=address,undefined -fno-sanitize=pointer-overflow,object-size \
                  -fsanitize=fuzzer-no-link -fno-sanitize-recover=all -fno-omit-frame-pointer -g1
define configure_sanitize
	$(call install_missing,$(CLANG_DEB_PACKAGES))
	cmake -S . -B $(SANITIZE_BUILD_DIR) -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS_RELEASE=-O3 \
	  -DCMAKE_CXX_COMPILER=clang++-14 \
	  "-DCMAKE_CXX_FLAGS=$(SANITIZE_FLAGS)" -DSLAMKIT_WARNINGS_AS_ERRORS=ON -DSLAMKIT_BUILD_FUZZ=ON \
	  -DSLAMKIT_BUILD_BENCH=OFF -DSLAMKIT_PORTABLE=ON
endef

# The suite (the Python module's and the browser test included) built with clang and run under the
# sanitizers. The allocation-counting tests count through the sanitizer's allocator hooks. Under the
# sanitizers a run takes 3 to 16 times as long, and each code path needs one run, not every world,
# seed, robot or thread count: the end-to-end runs below repeat a path another test in the sanitized
# suite takes (named after each), and stay in `make test`, where their accuracy bars are checked. (A
# value-parameterised test's name ends in a comment on its parameter, hence "( |$$)".)
SANITIZE_REPEATS := \
  ^TuningSeeds/VictoriaParkFastSlamSeed[.] \
  ^VictoriaParkSlam[.]FastSlam2WithHundredParticlesOnTheFullRun$$ \
  ^VictoriaParkSlam[.]UkfWithAdditiveControlNoiseWithinTenPercentOfTheEkf$$ \
  ^HardAssociation[.]FastSlamRelocalisationCloses \
  ^HardAssociation[.]FastSlamKeepsTwinLandmarksThatAreSeenTogether$$ \
  /FastSlamAllocation[.]SecondLapMakesNoHeapAllocation/(FastSlam2Known2Threads|FastSlam1Known2Threads|FastSlam2Nn1Threads|FastSlam2Known1Threads|FastSlam1Nn2Threads)( |$$) \
  ^Modes/EkfAllocationFree[.]SecondLapMakesNoHeapAllocation/CompressedNearestNeighbour( |$$) \
  ^Dataset6/MrclamSlam[.]SlamBeatsDeadReckoningAgainstMotionCapture/fastslam2_robot[1235]( |$$) \
  ^EkfCompressed[.]EqualsFullEkfOnLargeWorldAcrossManyAreas$$ \
  ^FastSlam[.]Version2HasLowerTrajectoryErrorThanVersion1$$ \
  ^FastSlamLoopClosure[.]HundredParticlesWithUnknownAssociationCloseTheLoop$$ \
  ^RangeCalibration[.]ARadioThatReadsLongIsCalibratedWhileItMaps$$ \
  ^RangeCalibration[.]FastSlamCalibratesARadioThatReadsLongWhileItMaps$$
# What takes each path instead: FastSLAM on Victoria Park's reader and detector, EkfWithJcbbOnTheFullRun
# and MRCLAM's fastslam2_robot4; the UKF, the simulated UKF tests; FastSLAM's relocalisation,
# FastSlamRelocalisationSearchesAtTheReturnOnly; FastSLAM's duplicate test and its fusions, the
# allocation-free lap's FastSlam1Nn1Threads (the default world driven twice); FastSLAM's allocation-free lap, its FastSlam1Known1Threads,
# FastSlam1Nn1Threads and FastSlam2Nn2Threads variants; FastSLAM 2.0 closing a loop by nearest
# neighbour without identities, FastSlamRelocalisationSearchesAtTheReturnOnly (the default world driven
# twice); the compressed EKF, its CompressedJcbb lap and
# EkfCompressed.SameDecisionsAndEstimateWithNearestNeighbourAssociation; FastSLAM 2.0's proposal, every
# FastSLAM 2.0 test above; the range calibration, Plaza1BeaconsLandWithinHalfAMetreOfTheSurvey and
# Plaza1FastSlamBeaconsLandWithinHalfAMetreOfTheSurvey.
space := $(subst ,, )
SANITIZE_EXCLUDE := $(subst $(space),|,$(strip $(SANITIZE_REPEATS)))
# ctest starts the longest tests first when it knows their times, which keeps both cores busy to the
# end; a fresh build knows none, so its first run takes them from tests/sanitize_test_seconds.txt (the
# sanitized suite's tests over 5 s as last measured; ctest's own CTestCostData format, kept by ctest
# from then on). ctest cannot record a test whose name holds a space, so the value-parameterised
# tests, named with their "# GetParam()" comment, are scheduled as short ones.
SANITIZE_COSTS := $(SANITIZE_BUILD_DIR)/Testing/Temporary/CTestCostData.txt
sanitize: test-deps
	$(configure_sanitize)
	cmake --build $(SANITIZE_BUILD_DIR) -j $(JOBS)
	@mkdir -p $(dir $(SANITIZE_COSTS)) && [ -f $(SANITIZE_COSTS) ] || cp tests/sanitize_test_seconds.txt $(SANITIZE_COSTS)
	cd $(SANITIZE_BUILD_DIR) && UBSAN_OPTIONS=print_stacktrace=1 ctest --output-on-failure -j $(JOBS) \
	  -E '$(SANITIZE_EXCLUDE)'

# Each libFuzzer target of fuzz/ for FUZZ_SECONDS, from its seed corpus; fails on any finding.
fuzz: test-deps
	$(configure_sanitize)
	cmake --build $(SANITIZE_BUILD_DIR) -j $(JOBS) --target slamkit_fuzz
	scripts/fuzz.sh $(SANITIZE_BUILD_DIR) $(FUZZ_SECONDS) out/fuzz

# README.md's result tables, regenerated: campaigns/readme.json's 223 runs (about 80 s on 2 cores;
# the real datasets from SLAMKIT_DATA or ../shared/datasets), then `report --into` replaces each
# table between its markers. The runs are made afresh, so the tables are this build's.
readme-tables: build
	rm -rf out/readme
	$(SLAMKIT) campaign campaigns/readme.json --out out/readme --no-report --quiet
	$(SLAMKIT) report out/readme/runs --out out/readme/report --no-nees --tables campaigns/readme.json --into README.md

# Long runs that keep no history: 10^6 EKF steps and 10^5 FastSLAM 2.0 steps with 100 particles,
# with the step rate and the memory as they go (about 10 minutes; not part of CI).
soak: build
	$(BUILD_DIR)/slamkit_soak --filter ekf --steps 1000000
	$(BUILD_DIR)/slamkit_soak --filter fastslam2 --particles 100 --steps 100000

clean:
	rm -rf $(BUILD_DIR) $(SANITIZE_BUILD_DIR) out
