#!/usr/bin/env bash
# The whole test suite, as CI runs it: installs what is missing, builds the
# optimized and the AddressSanitizer+UBSan configurations, and runs every
# test in both. Long stress and scale runs (ctest label `long`) are left out;
# run them with:  ctest --test-dir build/release -L long
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
source tools/setup.sh
install_missing_packages
for preset in release asan; do
  build_presets "$preset"
  echo "test: running the '$preset' suite" >&2
  ctest --preset "$preset"
done
echo "test: all suites passed (release and asan)" >&2
