#!/bin/sh
# Builds the libFuzzer harnesses (fuzz/harness/fuzz_*.cpp) with clang, AddressSanitizer and
# UndefinedBehaviorSanitizer into build-fuzz/ at the repository root.
# Usage: fuzz/build.sh [JOBS]   (default 1 job)
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
jobs=${1:-1}
cxx=${CXX_FUZZ:-$(command -v clang++ || command -v clang++-14)}
launcher=""
command -v ccache > /dev/null && launcher="-DCMAKE_CXX_COMPILER_LAUNCHER=ccache"
cmake -S "$root/fuzz" -B "$root/build-fuzz" -G Ninja -DCMAKE_BUILD_TYPE=None -DCMAKE_CXX_COMPILER="$cxx" $launcher
# The readers' harnesses first: they need only a small part of the library.
cmake --build "$root/build-fuzz" -j "$jobs" --target fuzz_obj fuzz_material fuzz_bvh fuzz_rig fuzz_tpose fuzz_weights
cmake --build "$root/build-fuzz" -j "$jobs"
