#!/usr/bin/env bash
# Size on disk of the dense and the sparse store on a mostly uniform volume:
# SIDE^3 points of one value (17) around a 16^3 block of noise (uint8), for
# each SIDE given (default 257 513). The dense store keeps an index entry
# for every block of the domain, empty ones included, so it grows with the
# domain; the sparse store keeps the nodes that carry information, so it
# stays the size of the noise. Prints one line per side: bytes of each store
# and their ratio.
#
#   bench/sparse_size_uniform.sh [SIDE...]     (1025: ~2 GB of disk, ~40 min on 2 cores)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
simplexdb=${SIMPLEXDB:-$PWD/build/release/tools/simplexdb}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
sides=("$@")
[[ ${#sides[@]} -gt 0 ]] || sides=(257 513)
printf "%-6s %14s %14s %8s %10s\n" side dense_bytes sparse_bytes ratio kept
for n in "${sides[@]}"; do
  python3 - "$n" "$work/u.nrrd" <<'PY'
import random, sys
n, path = int(sys.argv[1]), sys.argv[2]
random.seed(3)
with open(path, "wb") as out:
    out.write(f"NRRD0004\ntype: uint8\ndimension: 3\nsizes: {n} {n} {n}\n"
              "endian: little\nencoding: raw\n\n".encode())
    # The noise: a 16^3 block at about the middle.
    lo = n // 2 - 8
    plane = bytes([17]) * (n * n)
    for z in range(n):
        if not lo <= z < lo + 16:
            out.write(plane)
            continue
        p = bytearray(plane)
        for y in range(lo, lo + 16):
            for x in range(lo, lo + 16):
                p[y * n + x] = random.randint(0, 255)
        out.write(p)
PY
  "$simplexdb" import "$work/u.nrrd" -o "$work/u.sdb" -q
  "$simplexdb" import "$work/u.nrrd" --sparse -o "$work/u.lmdb" -q
  dense=$(stat -c %s "$work/u.sdb")
  sparse=$(stat -c %s "$work/u.lmdb")
  nodes=$("$simplexdb" info "$work/u.lmdb" --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["kept"])')
  printf "%-6s %14d %14d %8.2f %10d\n" "$n" "$dense" "$sparse" "$(python3 -c "print($dense / $sparse)")" "$nodes"
  rm -f "$work/u.nrrd" "$work/u.sdb" "$work/u.lmdb" "$work/u.lmdb-lock"
done
