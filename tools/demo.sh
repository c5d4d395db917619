#!/usr/bin/env bash
# The main job: builds SimplexDB and demonstrates it.
#
# First the two hierarchies: codes from the seed's worked examples with their
# vertices, face neighbors (found in constant time) and clusters, and the
# JSON contract of `simplexdb codes`. Then the dense store: a real CT volume
# (HT) and a real 4D fMRI volume (HP) from ../shared/data, or generated
# Perlin noise when that folder is absent, imported into stores, described,
# verified, the HP converted to the sparse (LMDB) store, the CT field
# exported back at half resolution, and meshes extracted from the CT store
# at two error thresholds (selective refinement) and written as .vtu, and
# from both HP stores. Last, the tool is installed as
# /usr/local/bin/simplexdb (on PATH) and the Python package under
# /usr/local (where Debian's python3 finds it), and its example is run on
# the CT scan. Everything it writes goes to out/demo/ (emptied at the start,
# kept at the end: open the .vtu files in ParaView).
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

work="$PWD/out/demo"
rm -rf "$work"
mkdir -p "$work"
data=../shared/data
echo
if [[ -f "$data/tooth/tooth_103x94x161_uint8.raw" ]]; then
  echo "== Import a real CT scan (103x94x161 uint8) into a Hierarchy of Tetrahedra"
  ht_input=("$data/tooth/tooth_103x94x161_uint8.raw" --dims 103,94,161 --type uint8)
else
  echo "== ($data is absent) Import 65^3 Perlin noise, the seed's Plasma64, into an HT"
  "$simplexdb" generate --field perlin --dims 65,65,65 --type uint8 -q -o "$work/plasma64.nrrd"
  ht_input=("$work/plasma64.nrrd")
fi
"$simplexdb" import "${ht_input[@]}" -o "$work/ht.sdb"
"$simplexdb" info "$work/ht.sdb"
"$simplexdb" verify "$work/ht.sdb"

echo
if [[ -f "$data/fmri_example4d/example4d.nii" ]]; then
  echo "== Import a real 4D fMRI volume (NIfTI, 128x96x24 over 2 time points) into a Hierarchy of Pentatopes"
  "$simplexdb" import "$data/fmri_example4d/example4d.nii" -o "$work/hp.sdb"
else
  echo "== Import 17^4 Perlin noise into a Hierarchy of Pentatopes"
  "$simplexdb" generate --field perlin --dims 17,17,17,17 --type float32 -q -o "$work/p17.nrrd"
  "$simplexdb" import "$work/p17.nrrd" -o "$work/hp.sdb"
fi
"$simplexdb" info "$work/hp.sdb"

echo
echo "== Convert it to the sparse LMDB store: only the diamonds with a non-zero error (lossless)"
"$simplexdb" convert "$work/hp.sdb" --to sparse -o "$work/hp.lmdb"
"$simplexdb" verify "$work/hp.lmdb"

echo
echo "== Export the HT store's field back out: the whole grid at every 2nd point"
"$simplexdb" export "$work/ht.sdb" --step 2 -o "$work/half.nrrd"

echo
echo "== Extract meshes from the HT store (selective refinement): 3% and 10% of the field range"
# Named fine and coarse, not by their numbers: ParaView shows files that
# differ by a number as one time series.
for e in 3% 10%; do
  name=$([[ $e == 3% ]] && echo fine || echo coarse)
  "$simplexdb" extract "$work/ht.sdb" --error "$e" --check --format vtu -o "$work/ht_$name.vtu" |
    python3 -c 'import json, sys; j = json.load(sys.stdin); n = j["simplices"]; f = j["full_resolution_simplices"]; print("  error {:>3}: {:>9,} tetrahedra of {:,.0f} ({:.2f}%), {:,} splits, {:,} cluster computations, {:.3f} s, conforming: {}".format(sys.argv[1], n, f, 100 * n / f, j["splits"], j["cluster_computations"], j["seconds"], j["conforming"]))' "$e"
done
ls -l "$work"/ht_*.vtu | awk '{print "  wrote " $NF " (" $5 " bytes; open it in ParaView)"}'

echo
echo "== The same query over both HP stores"
for store in hp.sdb hp.lmdb; do
  "$simplexdb" extract "$work/$store" --error 2% --format codes -o "$work/$store.codes" >/dev/null
  echo "  $store: $(stat -c %s "$work/$store") bytes, $(wc -l < "$work/$store.codes") pentatopes at 2%"
done
if cmp -s "$work/hp.sdb.codes" "$work/hp.lmdb.codes"; then
  echo "  (the same mesh: the lossless sparse store answers as the dense one)"
else
  echo "  the meshes differ: a lossless sparse store must answer as the dense one" >&2
  exit 1
fi

echo
echo "== The tool on PATH and the Python package where Debian's python3 finds it (/usr/local)"
sudo=()
if [[ $(id -u) -ne 0 ]]; then sudo=(sudo); fi
"${sudo[@]}" cmake --install build/release --component tool --prefix /usr/local |
  sed -n 's#^-- \(Installing\|Up-to-date\): \(.*/bin/simplexdb\)$#  installed \2#p'
"${sudo[@]}" cmake --install build/release --component python --prefix /usr/local |
  sed -n 's#^-- \(Installing\|Up-to-date\): \(.*/simplexdb\)/__init__.py$#  installed \2#p'
if [[ -f "$data/tooth/tooth_103x94x161_uint8.raw" ]]; then
  # Debian's interpreter, no PYTHONPATH: the installed package.
  (cd /tmp && /usr/bin/python3 "$OLDPWD/examples/python_thresholds.py" "$work/python" --data "$OLDPWD/$data") |
    sed 's/^/  /'
else
  /usr/bin/python3 -c 'import simplexdb; print("  import simplexdb:", simplexdb.__file__)'
fi

echo
echo "Everything above is in $work (kept until the next run): the stores,"
echo "the exported field, the meshes and the Python example's PNGs. To look at"
echo "a mesh: paraview \"$work/ht_fine.vtu\" (color by 'field' or 'error';"
echo "Debian: apt-get install paraview). Your own volume: simplexdb import, then"
echo "simplexdb extract (README, 'Your own volume'); from Python: import simplexdb."
