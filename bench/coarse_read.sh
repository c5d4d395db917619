#!/usr/bin/env bash
# Coarse reads, issue 16's target: `simplexdb export --step 4` of a whole
# 513^3 format-2 store against Python reading the every-4th-point level of
# a Zarr pyramid (Blosc-zstd, 64^3 chunks) of the same volume, each timed as
# a whole process by farm-bench (A: ours, B: Zarr; the ratio is A/B).
#
#   bench/coarse_read.sh [WORKDIR]     (default: a temporary directory)
#
# Needs build/release, farm-bench, and Debian's python3-zarr,
# python3-numcodecs and python3-numpy (installed with apt-get when run as
# root); about 1.5 GB free in WORKDIR.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
B="$PWD/build/release/tools/simplexdb"
WORK="${1:-$(mktemp -d)}"
mkdir -p "$WORK"
[[ $# -ge 1 ]] || trap 'rm -rf "$WORK"' EXIT
if ! /usr/bin/python3 -c "import zarr, numcodecs, numpy" 2>/dev/null; then
  [[ $(id -u) -eq 0 ]] || { echo "coarse_read: needs python3-zarr python3-numcodecs python3-numpy" >&2; exit 1; }
  apt-get install -y -qq --no-install-recommends python3-zarr python3-numcodecs python3-numpy >/dev/null
fi

volume="$WORK/perlin_513.nrrd"
[[ -f "$volume" ]] || "$B" generate --field perlin --dims 513,513,513 -o "$volume" -q
[[ -f "$WORK/p513.sdb" ]] || "$B" import "$volume" --memory-mb 4096 -o "$WORK/p513.sdb" -q
# The pyramid level: every 4th point of the generated volume (its voxels are
# the file's last 4 * 513^3 bytes), 129^3 float32.
[[ -d "$WORK/level4.zarr" ]] || /usr/bin/python3 - "$volume" "$WORK/level4.zarr" <<'PY'
import sys
import numcodecs
import numpy as np
import zarr
n = 513
values = np.fromfile(sys.argv[1], dtype="<f4")[-n ** 3:].reshape(n, n, n)
level = np.ascontiguousarray(values[::4, ::4, ::4])
z = zarr.open(sys.argv[2], mode="w", shape=level.shape, chunks=(64, 64, 64), dtype=level.dtype,
              compressor=numcodecs.Blosc(cname="zstd", clevel=5, shuffle=numcodecs.Blosc.SHUFFLE))
z[:] = level
PY
farm-bench -n 9 --timeout 300 \
  --vs "/usr/bin/python3 -c \"import zarr; zarr.open('$WORK/level4.zarr', mode='r')[:]\"" \
  -- "$B" export "$WORK/p513.sdb" --step 4 -o "$WORK/level4.nrrd" --force
