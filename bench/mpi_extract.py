#!/usr/bin/python3
"""Extraction under MPI against one process (issue 42): for each store and
query, the wall time of `simplexdb extract STORE ... -o X.vtu` and of
`mpirun --oversubscribe -np N simplexdb extract STORE ... -o X.pvtu`,
alternating, N runs each; the median of each and their ratio, with what
rank 0 reports (cells, rounds, bytes sent, largest piece over the mean).
The mpirun time includes its start-up.

    bench/mpi_extract.py STORE[:ERROR[:EXTRA...]] ... [--np 2] [--runs 3] [--work DIR]

ERROR defaults to 1%; EXTRA are more extract options, e.g.
perlin513_f32.sdb:0.25% or tooth.sdb:1%:--cache-mb:4. Needs build/release.
"""
import argparse
import json
import os
import statistics
import subprocess
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CLI = os.path.join(ROOT, "build", "release", "tools", "simplexdb")
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_btl_vader_single_copy_mechanism="none")


def timed(command):
    start = time.monotonic()
    p = subprocess.run(command, check=True, capture_output=True, text=True, env=ENV)
    return time.monotonic() - start, p.stdout


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("queries", nargs="+")
    parser.add_argument("--np", type=int, default=2)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--work", default="/tmp/simplexdb_mpi_bench")
    a = parser.parse_args()
    os.makedirs(a.work, exist_ok=True)
    print("| store, query | cells | one process (s) | mpirun -np %d (s) | ratio | rounds | bytes sent | largest / mean |"
          % a.np)
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for q in a.queries:
        store, *rest = q.split(":")
        error = rest[0] if rest else "1%"
        extra = rest[1:]
        query = ["--error", error] + extra
        vtu = os.path.join(a.work, "one.vtu")
        pvtu = os.path.join(a.work, "pieces.pvtu")
        one, many, stats = [], [], None
        for _ in range(a.runs):
            one.append(timed([CLI, "extract", store, "-o", vtu, "--force"] + query)[0])
            t, out = timed(["mpirun", "--oversubscribe", "-np", str(a.np), CLI, "extract", store, "-o", pvtu,
                            "--force"] + query)
            many.append(t)
            stats = json.loads(out)
        t1, tn = statistics.median(one), statistics.median(many)
        cells = sum(p["cells_written"] for p in stats["per_piece"])
        print(f"| {os.path.basename(store)} {' '.join(query)} | {cells:,} | {t1:.2f} | {tn:.2f} | {tn / t1:.2f} | "
              f"{stats['exchange_rounds']} | {stats['exchange_bytes_sent']:,} | {stats['largest_piece_over_mean']:.3f} |",
              flush=True)


if __name__ == "__main__":
    main()
