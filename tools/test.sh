#!/usr/bin/env bash
# The whole test suite, as CI runs it (.ci/run): installs what is missing,
# builds two configurations and runs the tests each is for, then prints how
# long every phase took and the suite's wall time.
#
# What each configuration runs, and why:
#
#   release (preset release: optimized, the build that ships) builds
#   everything, the benchmarks included (so they keep compiling), and runs
#   every test not labelled `long`: the whole suite, the CLI, the Python
#   package and the installed package included.
#
#   asan (preset asan: AddressSanitizer + UBSan at -O1, assertions on) is
#   for what only a sanitizer catches: a read past a buffer, a use after
#   free, a data race's torn state, undefined arithmetic on untrusted bytes.
#   Those live where bytes from outside are decoded and where memory is
#   managed by hand: the readers and parsers of volumes and stores, the
#   damage and corruption cases, the fuzz targets' saved inputs, the block
#   cache under concurrent readers, the memory bounds of the builders. So it
#   runs the tests labelled `util` or `storage`: util/ (UTF-8 and little-endian
#   decoding), every storage/ wing and every fuzz replay (label `fuzz`), and
#   builds only their executables (target sanitize_tests), about half of
#   the tree. It skips what a sanitizer adds little to, which the release
#   run covers: the hierarchy's location codes (pure arithmetic on 64-bit
#   values, checked exhaustively against reference implementations, so
#   undefined arithmetic there shows as a wrong answer), the refinement in
#   query/ (it reads stores only through the readers tested here), and the
#   CLI and Python front ends (processes and files around the same
#   library; the interpreter is not instrumented).
#
# Long stress and scale runs (label `long`) are left out of both; run them
# with  ctest --test-dir build/release -L long  (README, "Building by hand").
#
# The compiler cache (ccache, set up in CMakeLists.txt) makes a build of an
# unchanged source cheap, also in a fresh clone at another path; each build
# phase prints its hits and misses.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
source tools/setup.sh

suite_start=$SECONDS
phase_lines=()

# Prints the phases' times so far, also when a phase fails.
report_times() {
  local status=$?
  {
    echo "test: times (wall, seconds)"
    local line
    for line in "${phase_lines[@]}"; do echo "  $line"; done
    printf '  %-34s %5d s (%dm%02ds)\n' "whole suite" $((SECONDS - suite_start)) \
      $(((SECONDS - suite_start) / 60)) $(((SECONDS - suite_start) % 60))
    if ((status == 0)); then
      echo "test: all suites passed (release; asan on the util and storage tests)"
    else
      echo "test: FAILED (exit $status)"
    fi
  } >&2
}
trap report_times EXIT

# ccache's hit and miss counts (0 0 without ccache).
cache_counts() {
  if command -v ccache >/dev/null; then
    ccache --print-stats | awk '$1 ~ /^(direct|preprocessed)_cache_hit$/ {h += $2}
                                $1 == "cache_miss" {m = $2} END {print h + 0, m + 0}'
  else
    echo 0 0
  fi
}

# phase NAME COMMAND...: runs COMMAND and records its wall time.
phase() {
  local name=$1 start=$SECONDS
  shift
  echo "test: $name" >&2
  "$@"
  phase_lines+=("$(printf '%-34s %5d s' "$name" $((SECONDS - start)))")
}

# build PRESET: configures and builds a preset, noting ccache's hits.
build() {
  local before after
  read -r -a before < <(cache_counts)
  cmake --preset "$1" >/dev/null
  cmake --build --preset "$1"
  read -r -a after < <(cache_counts)
  echo "test: compiler cache for '$1': $((after[0] - before[0])) hits, $((after[1] - before[1])) misses" >&2
}

phase "install missing packages" install_missing_packages
phase "build release" build release
phase "test release (all but long)" ctest --preset release
phase "build asan (sanitize_tests)" build asan
phase "test asan (util, storage)" ctest --preset asan
