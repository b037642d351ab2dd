#!/usr/bin/env bash
# Builds the Debian packages (docs/install.md, "Debian packages") in a portable build: no
# -march=native, Debian's hardening flags (dpkg-buildflags), no tests or benchmarks. Writes
# shrm_*.deb, shrmd_*.deb, shrm-view_*.deb and libshrm-dev_*.deb into $SHRM_DEB_DIR (default
# build-deb/debs). Extra arguments go to the CMake configure step.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${SHRM_DEB_BUILD_DIR:-build-deb}
OUT_DIR=${SHRM_DEB_DIR:-$BUILD_DIR/debs}
# CMake reads CFLAGS/CXXFLAGS/LDFLAGS but not CPPFLAGS; all hardening (also bindnow); no -g (the
# packages hold no debug info).
export DEB_BUILD_MAINT_OPTIONS=hardening=+all DEB_CFLAGS_MAINT_STRIP=-g DEB_CXXFLAGS_MAINT_STRIP=-g
CFLAGS="$(dpkg-buildflags --get CPPFLAGS) $(dpkg-buildflags --get CFLAGS)" \
  CXXFLAGS="$(dpkg-buildflags --get CPPFLAGS) $(dpkg-buildflags --get CXXFLAGS)" \
  LDFLAGS=$(dpkg-buildflags --get LDFLAGS) \
  cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release -DSHRM_NATIVE=OFF \
  -DSHRM_BUILD_TESTS=OFF -DSHRM_BUILD_BENCH=OFF -DCMAKE_INSTALL_PREFIX=/usr "$@"
cmake --build "$BUILD_DIR" -j "${SHRM_JOBS:-$(nproc)}"
cpack -G DEB --config "$BUILD_DIR/CPackConfig.cmake" -B "$OUT_DIR"
ls -l "$OUT_DIR"/*.deb
