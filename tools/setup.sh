#!/usr/bin/env bash
# Installs the Debian packages SimplexDB needs (only the missing ones), then
# configures and builds the CMake presets named on the command line.
#
#   tools/setup.sh release        # optimized build in build/release
#   tools/setup.sh release asan   # and the AddressSanitizer+UBSan build
#
# Sourced or run by tools/demo.sh and tools/test.sh; safe to run again.
set -euo pipefail

# Why each package is here:
#   cmake, ninja-build, g++,       the build (pkg-config finds zstd and xxhash)
#   pkg-config
#   ccache                         compiles again only what changed, also in a
#                                  fresh clone (CMakeLists.txt sets it up)
#   libboost-dev                   boost::container::static_vector (hierarchy),
#                                  Boost.Interprocess for memory mapping (storage)
#   libzstd-dev                    compressed store blocks
#   liblmdb-dev                    the sparse store (a B-tree with MVCC readers)
#   libxxhash-dev                  block and header checksums (XXH3)
#   zlib1g-dev                     gzip-encoded NRRD input
#   libfmt-dev                     formatting in the tools
#   libcli11-dev                   the `simplexdb` command line
#   nlohmann-json3-dev             JSON output (`codes`, `--json`)
#   libgtest-dev, libgmock-dev     the test suites
#   libbenchmark-dev               the benchmark suites
#   python3-vtk9                   tests read the files we write with VTK itself
#   pybind11-dev, python3-dev      the Python package (python/)
#   python3-numpy                  its arrays
#   python3-pytest                 its tests
#   python3-matplotlib             examples/python_thresholds.py (and its test)
#   libopenmpi-dev, openmpi-bin    extraction in pieces under mpirun (parallel/)
PACKAGES=(
  cmake ninja-build g++ pkg-config ccache
  libboost-dev libzstd-dev liblmdb-dev libxxhash-dev zlib1g-dev
  libfmt-dev libcli11-dev nlohmann-json3-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  python3-vtk9 pybind11-dev python3-dev python3-numpy python3-pytest python3-matplotlib
  libopenmpi-dev openmpi-bin
)

install_missing_packages() {
  local missing=() p
  for p in "${PACKAGES[@]}"; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
      missing+=("$p")
    fi
  done
  if ((${#missing[@]} == 0)); then
    return 0
  fi
  echo "setup: installing ${missing[*]}" >&2
  local sudo=()
  if [[ $(id -u) -ne 0 ]]; then sudo=(sudo); fi
  "${sudo[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -qq --no-install-recommends \
    "${missing[@]}" >/dev/null
}

build_presets() {
  local preset
  for preset in "$@"; do
    echo "setup: building preset '$preset'" >&2
    cmake --preset "$preset" >/dev/null
    cmake --build --preset "$preset"
  done
}

main() {
  cd "$(dirname "${BASH_SOURCE[0]}")/.."
  install_missing_packages
  build_presets "$@"
}

if [[ "${BASH_SOURCE[0]}" == "$0" ]]; then
  main "${@:-release}"
fi
