#!/usr/bin/python3
"""The build under MPI against one process (issue 42): for each input, the
wall time of `simplexdb import INPUT -o A.sdb` and of `mpirun
--oversubscribe -np N simplexdb import INPUT -o B.sdb`, alternating, RUNS
runs each; the medians and their ratio; the peak memory of the one
process and of each rank (each rank's own VmHWM, as `import --json`
reports it); the slabs each rank built, the bytes it sent and its
exchanges; and whether the two stores are the same bytes. The mpirun time
includes its start-up.

    bench/mpi_build.py INPUT[:OPTION...] ... [--np 2] [--runs 3] [--work DIR]

OPTION are more import options, e.g. p513.nrrd:--memory-mb:400. Needs
build/release.
"""
import argparse
import filecmp
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
    return time.monotonic() - start, json.loads(p.stdout)


def mib(n):
    return f"{n / 2**20:.0f} MiB"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("inputs", nargs="+")
    parser.add_argument("--np", type=int, default=2)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--work", default="/tmp/simplexdb_mpi_build_bench")
    a = parser.parse_args()
    os.makedirs(a.work, exist_ok=True)
    print(f"| input | one process (s) | peak | mpirun -np {a.np} (s) | ratio | per rank: slabs, peak, sent, "
          "exchanges | same bytes |")
    print("|---|---:|---:|---:|---:|---|---|")
    for spec in a.inputs:
        path, *options = spec.split(":")
        one_store, many_store = os.path.join(a.work, "one.sdb"), os.path.join(a.work, "many.sdb")
        one, many = [], []
        one_report = many_report = None
        for _ in range(a.runs):
            t, one_report = timed([CLI, "import", path, "-o", one_store, "--force", "--json"] + options)
            one.append(t)
            t, many_report = timed(["mpirun", "--oversubscribe", "-np", str(a.np), CLI, "import", path, "-o",
                                    many_store, "--force", "--json"] + options)
            many.append(t)
        t1, tn = statistics.median(one), statistics.median(many)
        ranks = "; ".join(f"{r['slabs']}, {mib(r['peak_memory_bytes'])}, {mib(r['payload_bytes_sent'])}, "
                          f"{r['collectives']}" for r in many_report.get("ranks", []))
        same = filecmp.cmp(one_store, many_store, shallow=False)
        print(f"| {os.path.basename(path)} {' '.join(options)} | {t1:.2f} | {mib(one_report['peak_memory_bytes'])} "
              f"| {tn:.2f} | {tn / t1:.2f} | {ranks} | {'yes' if same else 'NO'} |", flush=True)


if __name__ == "__main__":
    main()
