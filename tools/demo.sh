#!/usr/bin/env bash
# The main job: builds SimplexDB and demonstrates it.
#
# Today it shows the two hierarchies: codes from the seed's worked examples
# with their vertices, face neighbors (found in constant time) and clusters,
# then the JSON contract of `simplexdb codes`.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
source tools/setup.sh
install_missing_packages
build_presets release >/dev/null
simplexdb=build/release/tools/simplexdb

echo
echo "== The seed's tetrahedron 210011 (section 3.2): its neighbors and cluster"
"$simplexdb" inspect --hierarchy ht 2:10011

echo
echo "== The six roots split the cube around its main diagonal"
"$simplexdb" inspect --hierarchy ht 0:

echo
echo "== A 1/8 pyramid at level 12 (the seed's example of 3.3) and a 1/2 pyramid below it"
"$simplexdb" inspect --hierarchy ht 1:010101011010 1:0101010110101

echo
echo "== The seed's pentatope 9010110 (section 4.3), an s-pentatope in the 4D hierarchy"
"$simplexdb" inspect --hierarchy hp 9:010110

echo
echo "== simplexdb codes (JSON lines, the contract outside checks read)"
printf '2:10011\n3:\n' | "$simplexdb" codes --hierarchy ht
printf '9:010110\n' | "$simplexdb" codes --hierarchy hp
