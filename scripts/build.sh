#!/usr/bin/env bash
# Configures and builds shrm (Release) into ./build. Extra arguments go to the CMake configure
# step, e.g. scripts/build.sh -DSHRM_NATIVE=OFF for a portable build.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${SHRM_BUILD_DIR:-build}
cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release "$@"
cmake --build "$BUILD_DIR" -j "${SHRM_JOBS:-$(nproc)}"
