#!/usr/bin/env bash
# Installs the Debian 12 packages pipetile needs, builds it, and runs the demo or the test suite.
#   bash tools/dev.sh demo   # mesh the bundled phantom into out/
#   bash tools/dev.sh test   # the whole test suite (what CI runs)
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(cmake g++ ccache clang-format libopenvdb-dev libboost-iostreams-dev libtbb-dev libglm-dev
          libgtest-dev libgmock-dev libbenchmark-dev libcli11-dev nlohmann-json3-dev libmeshoptimizer-dev
          libtinygltf-dev
          libopenvdb-tools libboost-python-dev pybind11-dev python3-pybind11 python3-numpy python3-pytest
          python3-openvdb python3-meshio python3-dask python3-distributed chromium)
# The HTML report's script is bundled with npm at build time, and its test drives Chromium with
# node; a node that brings its own npm (NodeSource's) is kept, else Debian's nodejs and npm come.
command -v npm >/dev/null 2>&1 || packages+=(nodejs npm)
if ! dpkg -s "${packages[@]}" >/dev/null 2>&1; then
  sudo=""; [ "$(id -u)" = 0 ] || sudo=sudo
  $sudo apt-get update -q
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -q "${packages[@]}"
fi

# ccache may serve any clone of the repository: paths relative to its root, build folder unhashed.
export CCACHE_BASEDIR="$PWD" CCACHE_NOHASHDIR=true
build=${PIPETILE_BUILD_DIR:-build}
# CI (the variable CI set, as CI services and .ci/run do) builds with warnings as errors.
werror=OFF; [ -z "${CI:-}" ] || werror=ON
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DPIPETILE_WERROR=$werror >/dev/null
case "${1:-demo}" in
  demo)
    cmake --build "$build" -j2 --target pipetile_cli
    mkdir -p out
    "$build/pipetile" mesh -o out/phantom.ply --report out/report.json
    ;;
  test)
    cmake --build "$build" -j2
    ctest --test-dir "$build" --output-on-failure -j2
    ;;
  *) echo "usage: bash tools/dev.sh demo|test" >&2; exit 2 ;;
esac
