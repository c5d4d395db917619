#!/usr/bin/env bash
# The dense store's scale runs: a SIDE^3 Perlin volume (uint8) built into an
# HT store within MEMORY_MB (`import --memory-mb`: the whole field in one
# window when it fits, else the widest window of planes that does), then
# read two ways:
#   - a 1% query in level order with a 256 MiB cache (`extract --json`:
#     seconds, splits per second, blocks decoded against distinct blocks);
#   - a million random lookups with a 64 MiB cache
#     (tests/storage/dense/memory_probe.cc), whose anonymous memory may grow
#     by at most the budget plus 16 MiB.
# Prints the build report (seconds, rate, peak memory), the store's info and
# both reads; fails if the build's peak resident memory exceeds MEMORY_MB or
# the reader's memory grows past its bound.
#
#   bench/scale_run.sh SIDE MEMORY_MB [WORK_DIR]
#
# ctest runs two (label "long", not in the default suite):
#   ScaleBuild1025: 1025 4096 (1.08 billion points, 6.4 billion
#     tetrahedra; the volume takes 1.1 GB of disk; one window);
#   ScaleBuild2049: 2049 4096 (8.6 billion points, 52 billion tetrahedra;
#     the volume takes 8.6 GB; several windows).
# The query holds its mesh in memory (a 1% mesh of 257^3 uint8 Perlin
# noise: 6.9 M tetrahedra, 274 MiB peak).
#
# With RANKS=N (N > 1) the volume is built a second time by `mpirun
# --oversubscribe -np N simplexdb import` with the same options (issue 42):
# prints that build's report (its time, each rank's slabs and peak memory),
# fails unless the file is the one-process store byte for byte and every
# rank's peak stays within MEMORY_MB. ctest runs ScaleBuild2049Mpi
# (RANKS=2, long).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
if [[ $# -lt 2 || $# -gt 3 ]]; then
  sed -n '2,/^set -euo/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//' >&2
  exit 2
fi
side=$1
limit_mb=$2
simplexdb=${SIMPLEXDB:-build/release/tools/simplexdb}
probe=${MEMORY_PROBE:-build/release/tests/storage/memory_probe}
work=${3:-$(mktemp -d)}
mkdir -p "$work"
volume="$work/perlin$side.nrrd"
store="$work/perlin$side.sdb"
ranks=${RANKS:-1}
trap 'rm -f "$volume" "$store" "$store.mpi"' EXIT
start=$(date +%s)
"$simplexdb" generate --field perlin --dims "$side,$side,$side" --type uint8 -q -o "$volume"
echo "generated in $(( $(date +%s) - start )) s" >&2
report=$("$simplexdb" import "$volume" -o "$store" --memory-mb "$limit_mb" --json -q)
echo "$report"
"$simplexdb" info "$store" --json
peak=$(python3 -c 'import json,sys; print(json.loads(sys.argv[1])["peak_memory_bytes"])' "$report")
if (( peak > limit_mb * 1024 * 1024 )); then
  echo "peak memory $peak bytes exceeds the ${limit_mb} MiB bound" >&2
  exit 1
fi
if (( ranks > 1 )); then
  export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 \
         OMPI_MCA_btl_vader_single_copy_mechanism=none
  mpi_report=$(mpirun --oversubscribe -np "$ranks" "$simplexdb" import "$volume" -o "$store.mpi" \
               --memory-mb "$limit_mb" --json -q)
  echo "$mpi_report"
  python3 -c '
import json, sys
one, many, limit = json.loads(sys.argv[1]), json.loads(sys.argv[2]), int(sys.argv[3]) << 20
print("one process: %.1f s, peak %.0f MiB; %d ranks: %.1f s (%.2fx), per rank %s"
      % (one["seconds"], one["peak_memory_bytes"] / 2**20, len(many["ranks"]), many["seconds"],
         many["seconds"] / one["seconds"],
         "; ".join("%d slabs, peak %.0f MiB, %.1f MiB sent"
                   % (r["slabs"], r["peak_memory_bytes"] / 2**20, r["payload_bytes_sent"] / 2**20)
                   for r in many["ranks"])))
over = [r for r in many["ranks"] if r["peak_memory_bytes"] > limit]
if over:
    sys.exit("ranks over the memory bound: %s" % over)
' "$report" "$mpi_report" "$limit_mb"
  cmp "$store" "$store.mpi"
  echo "the $ranks ranks wrote the one-process store byte for byte"
  rm -f "$store.mpi"
fi
query=$("$simplexdb" extract "$store" --error 1% --algorithm level-order --cache-mb 256 \
        --format json -o -)
python3 -c '
import json, sys
q = json.loads(sys.argv[1])
print("query at 1%%, level order, 256 MiB cache: %d simplices in %.2f s (%.2f M splits/s), "
      "%d blocks decoded, %d distinct, peak memory %.0f MiB"
      % (q["simplices"], q["seconds"], q["splits_per_second"] / 1e6, q["blocks_decoded"],
         q["distinct_blocks"], q["peak_memory_bytes"] / 2**20))
if q["simplices"] <= 6:
    sys.exit("the query did not refine")
' "$query"
budget=$((64 << 20))
read -r before after decoded < <("$probe" "$store" "$budget" 1000000 |
  sed -E 's/[a-z_]+=//g')
echo "reader: 1000000 random lookups, cache budget 64 MiB: anonymous memory $before KiB -> $after KiB, $decoded blocks decoded"
if (( after - before > (budget >> 10) + 16384 )); then
  echo "the reader's anonymous memory grew by $(( after - before )) KiB" >&2
  exit 1
fi
