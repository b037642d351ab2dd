#!/usr/bin/env bash
# Installs every Debian 12 package shrm needs (build, tests, benchmarks, service, viewer).
# Idempotent: packages already present are skipped by apt-get. Must run as root (or via sudo).
set -euo pipefail

PACKAGES=(
  # toolchain
  build-essential cmake ninja-build pkg-config git clang-format
  # image I/O and colour
  libopenimageio-dev openimageio-tools libopenexr-dev libopencolorio-dev
  # transforms
  libfftw3-dev
  # service
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler libabsl-dev libssl-dev
  # tests and benchmarks (libsharp: benchmark-only reference, GPL, never linked into shipped binaries)
  libgtest-dev libgmock-dev libbenchmark-dev libsharp-dev
  # fuzzing (scripts/fuzz.sh, docs/fuzzing.md): clang 14 with libFuzzer and the sanitizer runtimes
  clang libclang-rt-14-dev
  # the openssl CLI: tests/service_ops_test.cc makes its TLS certificates with it
  openssl
  # CLI and logging
  libcli11-dev libspdlog-dev nlohmann-json3-dev
  # viewer and headless rendering
  libglfw3-dev libepoxy-dev xvfb xauth libgl1-mesa-dri
  # viewer: OBJ meshes
  libtinyobjloader-dev
  # deployment test (tests/deploy_test.sh): nginx in front of shrmd replicas, a gRPC probe
  nginx python3-grpcio
  # engine test (tests/engines_test.sh): three.js in headless Chromium (WebGL2 on SwiftShader)
  chromium
  # installation and packaging (docs/install.md, tests/install_test.sh): man pages from --help,
  # the Debian packages' dependencies (dpkg-shlibdeps), their checks, bash completion
  help2man dpkg-dev lintian bash-completion
  # plots of the measurements in docs/results.md (scripts/plots.py)
  python3-matplotlib
)
# The deployment test renders and validates deploy/k8s with node (npm packages pinned in
# tests/deploy/k8s/package-lock.json). Debian's nodejs + npm unless a node is there already
# (e.g. NodeSource's nodejs, which bundles npm and conflicts with Debian's npm).
if ! command -v node >/dev/null 2>&1; then
  PACKAGES+=(nodejs npm)
fi

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
