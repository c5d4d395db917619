#!/usr/bin/python3
"""Out of core at every depth (issue 41): each query in memory, with a cache
of 2% of the decoded store (at least 1 MiB) and with a cache larger than the
store, in one run, as ratios to the in-memory rate; and blocks decoded
against the distinct blocks the query needs.

    bench/deep_queries.py [WORKDIR] [--runs N] [--only NAME] [--large]

Stores are built once in WORKDIR (default /tmp/simplexdb_deep) and reused.
Each configuration runs N times (default 3) as its own process; the table
gives the median rate. `--large` adds the 1025^3 uint8 store (about 1.2 GB
of input, minutes to build), queried at 1% and zoomed in (0.3%, a 200^3
corner box). Needs build/release.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CLI = os.path.join(ROOT, "build", "release", "tools", "simplexdb")
SHARED = os.path.join(os.path.dirname(ROOT), "shared", "data")


def run(args):
    return subprocess.run([CLI] + args, check=True, capture_output=True, text=True).stdout


def generated(work, name, dims, dtype, seed):
    """A Perlin store (simplexdb generate, default import), built once."""
    store = os.path.join(work, name + ".sdb")
    if not os.path.exists(store):
        volume = os.path.join(work, name + ".nrrd")
        run(["generate", "--field", "perlin", "--dims", dims, "--type", dtype, "--seed", str(seed),
             "-o", volume, "--quiet"])
        run(["import", volume, "--memory-mb", "8192", "-o", store, "--quiet"])
        os.remove(volume)
    return store


def shared(work, name, path, dims=None, dtype=None):
    store = os.path.join(work, name + ".sdb")
    if not os.path.exists(store):
        raw = ["--dims", dims, "--type", dtype] if dims else []  # NIfTI says them itself
        run(["import", os.path.join(SHARED, path)] + raw + ["-o", store, "--quiet"])
    return store


def extract(store, query, cache):
    args = ["extract", store, "--format", "json"] + query
    args += ["--in-memory"] if cache is None else ["--cache-mb", str(cache)]
    return json.loads(run(args))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("work", nargs="?", default="/tmp/simplexdb_deep")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--only", help="run only the queries whose name contains this")
    parser.add_argument("--large", action="store_true", help="add the 1025^3 store")
    a = parser.parse_args()
    os.makedirs(a.work, exist_ok=True)

    p257 = generated(a.work, "perlin257_u8", "257,257,257", "uint8", 5)
    p513 = generated(a.work, "perlin513_f32", "513,513,513", "float32", 5)
    queries = [
        ("257^3 uint8, 1%", p257, ["--error", "1%"]),
        ("257^3 uint8, 0.5%", p257, ["--error", "0.5%"]),
        ("513^3 float32, 1%", p513, ["--error", "1%"]),
        ("513^3 float32, 0.25%", p513, ["--error", "0.25%"]),
        ("HP 65^4 uint8, 1%", generated(a.work, "perlin65_4d_u8", "65,65,65,65", "uint8", 5), ["--error", "1%"]),
    ]
    if os.path.isdir(SHARED):
        for name, path, dims, dtype in [
            ("bucky", "bucky/bucky_32x32x32_uint8.raw", "32,32,32", "uint8"),
            ("neghip", "neghip/neghip_64x64x64_uint8.raw", "64,64,64", "uint8"),
            ("tooth", "tooth/tooth_103x94x161_uint8.raw", "103,94,161", "uint8"),
            ("headsq", "headsq/headsq_64x64x93_int16le.raw", "64,64,93", "int16"),
            ("lidc2", "lidc2/LIDC2_256x256x133_uint8.raw", "256,256,133", "uint8"),
        ]:
            queries.append((name + ", 1%", shared(a.work, name, path, dims, dtype), ["--error", "1%"]))
        queries.append(("fmri (HP), 1%", shared(a.work, "fmri", "fmri_example4d/example4d.nii"), ["--error", "1%"]))
    if a.large:
        p1025 = generated(a.work, "perlin1025_u8", "1025,1025,1025", "uint8", 5)
        queries.append(("1025^3 uint8, 1%", p1025, ["--error", "1%"]))
        queries.append(("1025^3 uint8, 0.3%, box 200^3", p1025,
                        ["--error", "0.3%", "--box", "0,0,0,200,200,200"]))

    print("| query | simplices | in memory (M splits/s) | cache 2% (MiB) | rate | ratio | decoded / distinct "
          "| cache > store (MiB) | rate | ratio | decoded / distinct |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for name, store, query in queries:
        if a.only and a.only not in name:
            continue
        logical = json.loads(run(["info", store, "--json"]))["logical_bytes"]
        small = max(1, round(0.02 * logical / 2**20))
        # Larger than the store: the decoded blocks and bricks, and the
        # finest errors' boxes (as large again, and more, for u16 codes).
        large = max(64, 4 * logical // 2**20)
        cells = []
        rates = {}
        for cache in (None, small, large):
            runs = [extract(store, query, cache) for _ in range(a.runs)]
            rates[cache] = statistics.median(r["splits_per_second"] for r in runs)
            last = runs[-1]
            if cache is None:
                cells += [f"{last['simplices']:,}", f"{rates[cache] / 1e6:.2f}"]
            else:
                cells += [str(cache), f"{rates[cache] / 1e6:.2f}", f"{rates[cache] / rates[None]:.2f}x",
                          f"{last['blocks_decoded']:,} / {last['distinct_blocks']:,}"]
        print(f"| {name} | " + " | ".join(cells) + " |")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
