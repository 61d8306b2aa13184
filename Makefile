# Entry points: `make demo` and `make test` work on a fresh Debian 12 machine (as root).
BUILD ?= build
JOBS ?= $(shell nproc)
PACKAGES := cmake ninja-build g++ libeigen3-dev nlohmann-json3-dev libcli11-dev \
            libgtest-dev libbenchmark-dev libpng-dev libtbb-dev gnuplot-nox ffmpeg \
            clang libclang-rt-14-dev libcpp-httplib-dev pkg-config chromium \
            python3-dev pybind11-dev python3-pybind11 python3-numpy python3-pytest \
            python3-distributed python3-pandas

.PHONY: all deps build demo test sanitize fuzz bench results clean

all: build

deps:
	@missing=""; for p in $(PACKAGES); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ]; then \
	  echo "Installing:$$missing"; \
	  if [ "$$(id -u)" -ne 0 ]; then SUDO=sudo; else SUDO=; fi; \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq $$missing; \
	fi
	@# node and npm run the glTF validator of the tests (tools/validate) and bundle the viewer's
	@# page (viewer/, `weft view`); a node installed
	@# otherwise (not from Debian) is kept.
	@if ! command -v npm >/dev/null 2>&1; then \
	  echo "Installing: nodejs npm"; \
	  if [ "$$(id -u)" -ne 0 ]; then SUDO=sudo; else SUDO=; fi; \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq nodejs npm; \
	fi

$(BUILD)/build.ninja: | deps
	cmake -S . -B $(BUILD) -G Ninja -DCMAKE_BUILD_TYPE=Release

build: deps $(BUILD)/build.ninja
	cmake --build $(BUILD) -j $(JOBS)

# The demo needs only the command, not the tests or the benchmarks.
demo: deps $(BUILD)/build.ninja
	cmake --build $(BUILD) -j $(JOBS) --target weft
	$(BUILD)/weft run scenes/swing.json --out out/swing
	@echo "Results: out/swing (frames/, energy.csv, summary.json)"

# The Khronos glTF validator at the versions tools/validate/package-lock.json pins.
VALIDATOR := tools/validate/node_modules/.package-lock.json
$(VALIDATOR): tools/validate/package.json tools/validate/package-lock.json | deps
	npm ci --prefix tools/validate --no-audit --no-fund

test: deps $(BUILD)/build.ninja $(VALIDATOR)
	cmake --build $(BUILD) -j $(JOBS) --target weft weft_viewer weft_tests
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

# The test suite under AddressSanitizer and UndefinedBehaviorSanitizer, in its own folder, built
# by clang (-O2, so the suite runs in minutes); the same folder holds the readers' libFuzzer
# harnesses (fuzz/), which `make fuzz` runs for FUZZ_SECONDS each.
SAN_BUILD ?= build-san
# Tests left out of the sanitizer run: long scenes whose code paths shorter tests of the same
# suite already cover under the sanitizers (the normal `make test` runs them all). Together they
# took about two thirds of the sanitizer run's time.
SAN_SKIP := ^(Checkpoint\.Killed(Rk45|ImplicitMidpoint|Multigrid)RunResumesToTheSameBytes|CollisionScenes\.(SheetOnTheWalkingBody|SelfCollisionDoesNotStretch|TwistedSheet|ShirtOnTheMannequin).*|SelfContact\.StackedSheets.*|CantileverExperiment\.BendingLengthMatchesTheAnalyticValueForTwoMaterials)$$
FUZZ_SECONDS ?= 10
$(SAN_BUILD)/build.ninja: | deps
	cmake -S . -B $(SAN_BUILD) -G Ninja -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=Release \
	  -DCMAKE_CXX_FLAGS_RELEASE="-O2 -DNDEBUG" -DWEFT_SANITIZE=address,undefined -DWEFT_FUZZ=ON -DWEFT_BUILD_BENCH=OFF

sanitize: deps $(SAN_BUILD)/build.ninja $(VALIDATOR)
	cmake --build $(SAN_BUILD) -j $(JOBS) --target weft weft_viewer weft_tests
	cd $(SAN_BUILD) && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
	  ctest --output-on-failure -j $(JOBS) -E '$(SAN_SKIP)' $(SAN_CTEST_ARGS)

fuzz: deps $(SAN_BUILD)/build.ninja
	cmake --build $(SAN_BUILD) -j $(JOBS) --target weft_fuzz
	FUZZ_BUILD=$(SAN_BUILD)/fuzz sh fuzz/run.sh $(FUZZ_SECONDS)

# Benchmarks are built for the building machine's CPU (-march=native) in their own folder;
# the figures in docs/performance.md say which build gave them.
BENCH_BUILD ?= build-native
bench: deps
	cmake -S . -B $(BENCH_BUILD) -G Ninja -DCMAKE_BUILD_TYPE=Release -DWEFT_NATIVE=ON -DWEFT_BUILD_TESTS=OFF -DWEFT_PYTHON=OFF
	cmake --build $(BENCH_BUILD) -j $(JOBS) --target weft_bench
	$(BENCH_BUILD)/weft_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true

results: build
	sh tools/results.sh

clean:
	rm -rf $(BUILD)
