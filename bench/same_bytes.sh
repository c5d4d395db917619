#!/usr/bin/env bash
# Fingerprints what the `simplexdb` command writes from the shared volumes
# (../shared/data) and a few generated ones: dense and sparse stores, meshes
# (.vtu and leaf codes), exports and conversions. One line per output,
# "<sha256>  <name>", sorted. Run it with two builds and diff the lists to
# show that a change kept the bytes:
#
#   bench/same_bytes.sh OLD_SIMPLEXDB /tmp/old > old.txt
#   bench/same_bytes.sh build/release/tools/simplexdb /tmp/new > new.txt
#   diff old.txt new.txt
#
# Builds run with --threads 1 (a dense store's bricks land in the order the
# threads finish them). Stores built with a mask or with missing values are
# listed under "masked/": their bytes may change with the build path; their
# meshes (codes, .vtu) may not.
set -euo pipefail
B="$(realpath "${1:?usage: same_bytes.sh SIMPLEXDB WORKDIR}")"
WORK="${2:?usage: same_bytes.sh SIMPLEXDB WORKDIR}"
DATA="$(cd "$(dirname "${BASH_SOURCE[0]}")/../../shared/data" && pwd)"
rm -rf "$WORK"
mkdir -p "$WORK"
cd "$WORK"

q() { "$B" "$@" -q >/dev/null; }  # commands with --quiet
# A box of a store's grid: from a quarter to a half of each space axis.
box() {
  "$B" info "$1" --json | /usr/bin/python3 -c '
import json, sys
d = json.load(sys.stdin)["dims"][:3]
print(",".join(str(n // 4) for n in d) + "," + ",".join(str(n // 2) for n in d))'
}
r() { "$B" "$@" >/dev/null; }     # the others

# name input-args...
volumes=(
  "tooth|$DATA/tooth/tooth_103x94x161_uint8.raw --dims 103,94,161 --type uint8"
  "neghip|$DATA/neghip/neghip_64x64x64_uint8.raw --dims 64,64,64 --type uint8"
  "bucky|$DATA/bucky/bucky_32x32x32_uint8.raw --dims 32,32,32 --type uint8"
  "headsq|$DATA/headsq/headsq_64x64x93_int16le.raw --dims 64,64,93 --type int16"
  "lidc2|$DATA/lidc2/LIDC2_256x256x133_uint8.raw --dims 256,256,133 --type uint8"
  "fmri|$DATA/fmri_example4d/example4d.nii"
  "dwi|$DATA/dwi_small_101D/small_101D.nii"
)
q generate --field perlin --dims 65,65,65 --type float32 --seed 3 -o perlin65.nrrd
q generate --field sines --dims 17,19,13,9 --type float32 -o sines4d.nrrd
volumes+=("perlin65|perlin65.nrrd" "sines4d|sines4d.nrrd")

for entry in "${volumes[@]}"; do
  name="${entry%%|*}"
  read -r -a input <<<"${entry#*|}"
  q import "${input[@]}" --threads 1 -o "$name.sdb"
  q import "${input[@]}" --threads 1 --quantization f32 --compression none -o "$name.f32.sdb"
  q import "${input[@]}" --threads 1 --memory-mb 8 -o "$name.streamed.sdb" 2>/dev/null ||
    echo "refused" >"$name.streamed.sdb"
  q import "${input[@]}" --threads 1 --sparse -o "$name.sparse.sdb"
  q import "${input[@]}" --threads 1 --sparse --tolerance 2% -o "$name.sparse2.sdb"
  time=()
  if [[ $name == fmri || $name == dwi || $name == sines4d ]]; then time=(--time 1); fi
  for store in "$name.sdb" "$name.sparse.sdb" "$name.sparse2.sdb"; do
    for e in 1% 5%; do
      r extract "$store" --error "$e" "${time[@]}" --format codes -o "$store.$e.codes"
      r extract "$store" --error "$e" "${time[@]}" -o "$store.$e.vtu"
    done
    r extract "$store" --error 0.5% --box "$(box "$store")" "${time[@]}" --format codes -o "$store.box.codes"
  done
  q convert "$name.sdb" --to sparse --tolerance 1% -o "$name.to_sparse.sdb"
  q convert "$name.sparse2.sdb" --to dense -o "$name.to_dense.sdb"
  if [[ -z ${time[*]} ]]; then
    r export "$name.sdb" -o "$name.export.nrrd"
    r export "$name.sdb" --step 2 -o "$name.export2.raw"
  fi
done

# Missing values: a mask (the tooth's voxels below 40 masked out) and NaN.
/usr/bin/python3 - "$DATA" <<'EOF'
import sys, numpy as np
data = sys.argv[1]
t = np.fromfile(f"{data}/tooth/tooth_103x94x161_uint8.raw", np.uint8)
with open("tooth_mask.nrrd", "wb") as f:
    f.write(b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 103 94 161\nencoding: raw\n\n")
    f.write((t >= 40).astype(np.uint8).tobytes())
n = np.fromfile(f"{data}/neghip/neghip_64x64x64_uint8.raw", np.uint8).astype(np.float32)
n[n < 20] = np.nan
n.tofile("neghip_nan.raw")
EOF
mkdir -p masked
q import "$DATA/tooth/tooth_103x94x161_uint8.raw" --dims 103,94,161 --type uint8 --threads 1 \
  --mask tooth_mask.nrrd -o masked/tooth.sdb
q import neghip_nan.raw --dims 64,64,64 --type float32 --threads 1 -o masked/neghip_nan.sdb
for store in masked/tooth.sdb masked/neghip_nan.sdb; do
  for e in 0 1% 5%; do
    r extract "$store" --error "$e" --format codes -o "$store.$e.codes"
    r extract "$store" --error "$e" -o "$store.$e.vtu"
  done
  r extract "$store" --error 0.5% --box "$(box "$store")" --format codes -o "$store.box.codes"
  r export "$store" -o "$store.export.nrrd"
done

rm -f perlin65.nrrd sines4d.nrrd tooth_mask.nrrd neghip_nan.raw
find . -type f | sort | while read -r f; do
  printf '%s  %s\n' "$(sha256sum <"$f" | cut -d' ' -f1)" "${f#./}"
done
