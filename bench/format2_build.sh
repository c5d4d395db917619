#!/usr/bin/env bash
# Build rates of the dense store (format 2) in one run: `import --json` of
# Perlin noise (HT 257^3, HT 513^3, HP 33^4) and two real volumes. Prints
# one line per import: grid points, seconds, grid points per second, peak
# memory, file bytes, how the errors were computed. (Format 1's rates,
# before it was replaced, are in bench/README.md.)
#
#   bench/format2_build.sh [WORKDIR]     (default: a temporary directory)
#
# Needs build/release (cmake --preset release && cmake --build build/release)
# and about 2 GB free in WORKDIR.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
B="$PWD/build/release/tools/simplexdb"
DATA="$PWD/../shared/data"
WORK="${1:-$(mktemp -d)}"
mkdir -p "$WORK"
[[ $# -ge 1 ]] || trap 'rm -rf "$WORK"' EXIT

for spec in 257,257,257 513,513,513 33,33,33,33; do
  [[ -f "$WORK/perlin_$spec.nrrd" ]] ||
    "$B" generate --field perlin --dims "$spec" -o "$WORK/perlin_$spec.nrrd" -q
done

summary='
import json, sys
j = json.load(sys.stdin)
points, seconds, rate = j["grid_points"], j["seconds"], j["grid_points_per_second"] / 1e6
peak, size = j["peak_memory_bytes"] / 2**20, j["file_bytes"] / 2**20
method = j["error_method"]
print("%12d points %8.2f s %6.2f M/s peak %7.0f MiB %8.1f MiB %s" % (points, seconds, rate, peak, size, method))
'
run() {
  local name="$1"
  shift
  printf '%-30s ' "$name"
  # Not over the previous store: replacing it frees its blocks inside the
  # timed rename (0.4 s for the 293 MiB of 513^3).
  rm -f "$WORK/out.sdb"
  "$B" import "$@" -o "$WORK/out.sdb" --json -q | python3 -c "$summary"
}

tooth=("$DATA/tooth/tooth_103x94x161_uint8.raw" --dims 103,94,161 --type uint8)
fmri=("$DATA/fmri_example4d/example4d.nii")
run "HT perlin 257^3" "$WORK/perlin_257,257,257.nrrd"
run "HT perlin 513^3" "$WORK/perlin_513,513,513.nrrd"
run "HP perlin 33^4" "$WORK/perlin_33,33,33,33.nrrd"
run "HT tooth" "${tooth[@]}"
run "HP fmri" "${fmri[@]}"
