#!/usr/bin/python3
"""Two builds of simplexdb on the same deep queries, in alternating runs
(issue 41): each pair runs BEFORE then AFTER, in memory and with the
query's cache; prints each build's median ratio to its in-memory rate, the
median of the pairs' ratios of cached rates (after / before), and the
blocks each decoded.

    bench/paired_queries.py BEFORE_CLI AFTER_CLI [WORKDIR] [--pairs N] [--only NAME]

WORKDIR holds the stores bench/deep_queries.py builds (run it first);
default /tmp/simplexdb_deep. Pairing keeps the ratio meaningful when the
machine's speed drifts between runs.
"""
import argparse
import json
import os
import statistics
import subprocess

QUERIES = [
    ("257^3 uint8, 1%", "perlin257_u8.sdb", ["--error", "1%"], 1),
    ("257^3 uint8, 0.5%", "perlin257_u8.sdb", ["--error", "0.5%"], 1),
    ("513^3 float32, 0.25%", "perlin513_f32.sdb", ["--error", "0.25%"], 13),
    ("513^3 float32, 1%", "perlin513_f32.sdb", ["--error", "1%"], 13),
    ("HP 65^4 uint8, 1%", "perlin65_4d_u8.sdb", ["--error", "1%"], 1),
    ("fmri (HP), 1%", "fmri.sdb", ["--error", "1%"], 1),
    ("tooth, 1%", "tooth.sdb", ["--error", "1%"], 1),
    ("lidc2, 1%", "lidc2.sdb", ["--error", "1%"], 1),
]


def extract(cli, store, query, cache):
    args = [cli, "extract", store, "--format", "json"] + query
    args += ["--in-memory"] if cache is None else ["--cache-mb", str(cache)]
    return json.loads(subprocess.run(args, check=True, capture_output=True, text=True).stdout)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("before")
    parser.add_argument("after")
    parser.add_argument("work", nargs="?", default="/tmp/simplexdb_deep")
    parser.add_argument("--pairs", type=int, default=5)
    parser.add_argument("--only", help="run only the queries whose name contains this")
    a = parser.parse_args()
    print("| query | cache (MiB) | ratio to in memory, before | after | after / before | decoded before | after |")
    print("|---|---|---|---|---|---|---|")
    for name, store, query, cache in QUERIES:
        path = os.path.join(a.work, store)
        if (a.only and a.only not in name) or not os.path.exists(path):
            continue
        ratios = {"before": [], "after": []}
        pairs, decoded = [], {}
        for _ in range(a.pairs):
            rate = {}
            for side, cli in (("before", a.before), ("after", a.after)):
                in_memory = extract(cli, path, query, None)["splits_per_second"]
                j = extract(cli, path, query, cache)
                rate[side] = j["splits_per_second"]
                ratios[side].append(rate[side] / in_memory)
                decoded[side] = j["blocks_decoded"]
            pairs.append(rate["after"] / rate["before"])
        print(f"| {name} | {cache} | {statistics.median(ratios['before']):.2f}x | "
              f"{statistics.median(ratios['after']):.2f}x | {statistics.median(pairs):.2f} | "
              f"{decoded['before']:,} | {decoded['after']:,} |", flush=True)


if __name__ == "__main__":
    main()
