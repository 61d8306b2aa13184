# Entry points: `make demo` and `make test` work on a fresh Debian 12 machine (as root).
BUILD ?= build
JOBS ?= $(shell nproc)
PACKAGES := cmake ninja-build g++ libeigen3-dev nlohmann-json3-dev libcli11-dev \
            libgtest-dev libbenchmark-dev libpng-dev libtinyobjloader-dev gnuplot-nox

.PHONY: all deps build demo test bench results clean

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

$(BUILD)/build.ninja: | deps
	cmake -S . -B $(BUILD) -G Ninja -DCMAKE_BUILD_TYPE=Release

build: deps $(BUILD)/build.ninja
	cmake --build $(BUILD) -j $(JOBS)

demo: build
	$(BUILD)/weft run scenes/swing.json --out out/swing
	@echo "Results: out/swing (frames/, energy.csv, summary.json)"

test: build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

bench: build
	$(BUILD)/weft_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true

results: build
	sh tools/results.sh

clean:
	rm -rf $(BUILD)
