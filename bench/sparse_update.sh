#!/usr/bin/env bash
# The sparse store's in-place update against importing anew: a Perlin volume
# of SIDE^3 points (default 257), imported as a lossless sparse store; then a
# 32^3 box gets new values (noise within the field range) and the store is
# updated in place (`simplexdb update`) and, for comparison, the changed
# volume is imported from scratch. Prints both times and peak memories, and
# fails unless both stores hold the same counts and give the same 2% mesh.
#
#   bench/sparse_update.sh [WORK_DIR] [SIDE]     (257: ~1.5 GB of disk, ~2 min)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
simplexdb=${SIMPLEXDB:-$PWD/build/release/tools/simplexdb}
work=${1:-$(mktemp -d)}
side=${2:-257}
mkdir -p "$work"
cd "$work"
trap 'rm -f a.nrrd c.nrrd a.lmdb a.lmdb-lock fresh.lmdb fresh.lmdb-lock' EXIT
"$simplexdb" generate --field perlin --dims "$side,$side,$side" --type uint8 --seed 2 -q -o a.nrrd
# c.nrrd: a.nrrd with noise in the box x 100..131, y 60..91, z 150..181
# (scaled down for smaller sides).
box=$(python3 - "$side" <<'PY'
import random, sys
n = int(sys.argv[1])
data = open('a.nrrd', 'rb').read()
end = data.index(b'\n\n') + 2
head, body = data[:end], bytearray(data[end:])
lo, hi = min(body), max(body)
x0, y0, z0 = (100 * n) // 257, (60 * n) // 257, (150 * n) // 257
w = min(32, n - max(x0, y0, z0))
random.seed(1)
for z in range(z0, z0 + w):
    for y in range(y0, y0 + w):
        row = n * (y + n * z)
        for x in range(x0, x0 + w):
            body[row + x] = random.randint(lo, hi)
open('c.nrrd', 'wb').write(head + bytes(body))
print(f"{x0},{y0},{z0},{x0 + w - 1},{y0 + w - 1},{z0 + w - 1}")
PY
)
/usr/bin/time -f "import a.nrrd --sparse: %e s, peak %M KiB" "$simplexdb" import a.nrrd --sparse -o a.lmdb -q
/usr/bin/time -f "update --box $box: %e s, peak %M KiB" "$simplexdb" update a.lmdb c.nrrd --box "$box"
/usr/bin/time -f "import c.nrrd --sparse (anew): %e s, peak %M KiB" "$simplexdb" import c.nrrd --sparse -o fresh.lmdb -q
summary() {
  "$simplexdb" info "$1" --json |
    python3 -c 'import json,sys; j=json.load(sys.stdin); print(j["kept"], j["blocks"], j["error_max"])'
}
got=$(summary a.lmdb)
want=$(summary fresh.lmdb)
echo "updated: $got; imported anew: $want (kept vertices, blocks, largest error)"
[[ "$got" == "$want" ]] || { echo "the updated store differs from a fresh import" >&2; exit 1; }
cmp <("$simplexdb" extract a.lmdb --error 2% --format codes -o -) \
    <("$simplexdb" extract fresh.lmdb --error 2% --format codes -o -) ||
  { echo "the updated store's 2% mesh differs from a fresh import's" >&2; exit 1; }
