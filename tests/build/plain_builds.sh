#!/usr/bin/env bash
# An embedder's build compiles cleanly: configures SimplexDB without the
# presets, as `cmake -DCMAKE_BUILD_TYPE=...` alone would, in a Release
# (-O3) build and a Debug build with the default compiler and a Release
# build with clang++, each with SIMPLEXDB_WERROR=ON, and builds the
# libraries and the `simplexdb` command (tests and benchmarks off). Fails on
# any warning: -Werror covers our targets, and the build log is searched for
# "warning:" too. Skips the clang build, saying so, when clang++ is absent.
#
#   plain_builds.sh SOURCE_DIR [GENERATOR]
#
# ctest's PlainBuilds (label "long": a few minutes per build on 2 cores).
# JOBS (default 2) sets the build's parallelism; CLANGXX names the clang++
# to use (default: clang++ on PATH; empty skips the clang build).
set -euo pipefail
source=$1 generator=${2:-Ninja}
jobs=${JOBS:-2}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

failed=()
build() {  # build NAME CMAKE_ARGS...
  local name=$1
  shift
  local dir="$work/$name" start=$SECONDS
  echo "== $name: $*"
  if ! cmake -S "$source" -B "$dir" -G "$generator" -DSIMPLEXDB_WERROR=ON \
         -DSIMPLEXDB_BUILD_TESTS=OFF -DSIMPLEXDB_BUILD_BENCH=OFF "$@" > "$dir.configure.log" 2>&1; then
    cat "$dir.configure.log" >&2
    echo "== $name: configure failed" >&2
    failed+=("$name")
    return
  fi
  local status=0
  # Keep going after an error, so the log shows every warning at once.
  local keep_going=()
  [[ "$generator" == Ninja ]] && keep_going=(-- -k 0)
  cmake --build "$dir" -j "$jobs" "${keep_going[@]}" > "$dir.build.log" 2>&1 || status=$?
  if (( status != 0 )) || grep -q 'warning:' "$dir.build.log"; then
    # The compiler's messages only, not the list of commands.
    grep -v '^\[[0-9]*/[0-9]*\] ' "$dir.build.log" >&2 || true
    echo "== $name: FAILED after $(( SECONDS - start )) s: warnings or errors above" \
         "(build exit status $status)" >&2
    failed+=("$name")
    return
  fi
  echo "== $name: clean in $(( SECONDS - start )) s"
}

build release -DCMAKE_BUILD_TYPE=Release
build debug -DCMAKE_BUILD_TYPE=Debug
clang=${CLANGXX-$(command -v clang++ || true)}
if [[ -n "$clang" && -x "$clang" ]]; then
  build clang-release -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER="$clang"
else
  echo "== clang-release: SKIPPED, clang++ is not installed (not on PATH)"
fi

if (( ${#failed[@]} )); then
  echo "builds with warnings or errors: ${failed[*]}" >&2
  exit 1
fi
