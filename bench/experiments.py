#!/usr/bin/python3
"""Reruns the seed's experiments with SimplexDB and writes bench/RESULTS.md.

    bench/experiments.py [--quick] [--work DIR]

What it runs (issue 7), each with the `simplexdb` tool or a Google Benchmark
suite of this build (build/release, built first if missing):

  1. Mesh sizes (seed Figs. 48-50, 3D; Figs. 63-64, 4D): `simplexdb extract`
     at 0, 0.1, 0.5, 1, 5 and 10 % of the field range, for a uniform
     criterion, a box and an isovalue, over the seed's data sets rebuilt here
     (Plasma64: 65^3 Perlin noise; Buckyball: a 129^3 C60 density; the 4D
     Buckyball: its 4x4x4 subgrids as time, 33^4; a 33^4 Perlin set in place
     of the Richtmyer-Meshkov subset we do not have) and the real volumes of
     ../shared/data. 4D queries are held to the time slice t = 4 as in Fig. 63.
  2. Saturation (3.7, 4.7): the same uniform queries with --algorithm
     saturated; the seed found +5 % simplices in 3D and under 1 % in 4D.
  3. Throughput per store (Fig. 46): bench/query_bench, every store and
     algorithm in one run, as ratios to in-memory.
  4. Sizes: each data set's store in bytes per grid point (field bricks and
     error blocks apart), beside format 1's.
  5. Scale: building HT stores of 65^3, 257^3 and 1025^3 Perlin noise, then
     one query (1 % of the range) over each with a 256 MiB cache; build rate,
     throughput and memory, beside format 1's figures. --quick leaves out
     1025^3 (1.6 GiB of memory to build, a few minutes).
  6. Pictures: gnuplot plots of mesh size against threshold and of throughput
     per store, and slices through extracted meshes (read with VTK, drawn as
     SVG) like the seed's Figs. 47 and 57-59.

Stores and volumes go to --work (default /tmp/simplexdb-experiments) and are
reused when present; bench/RESULTS.md and bench/results/*.svg are rewritten.
Needs Debian's gnuplot-nox and python3-vtk9 (installed with apt-get when
missing and running as root).
"""
import argparse
import datetime
import json
import os
import platform
import shutil
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BUILD = os.path.join(ROOT, "build", "release")
SIMPLEXDB = os.path.join(BUILD, "tools", "simplexdb")
QUERY_BENCH = os.path.join(BUILD, "bench", "query_bench")
DATA = os.path.join(os.path.dirname(ROOT), "shared", "data")
OUT_DIR = os.path.join(ROOT, "bench", "results")
THRESHOLDS = [0, 0.1, 0.5, 1, 5, 10]

# The seed's figures, for comparison (Figs. 48, 49, 50, 63).
SEED_3D = {
    "plasma64": {"uniform": {0.1: 1493696, 0.5: 620996, 1: 337384, 5: 16800, 10: 2818},
                 "iso": {0: 19070, 0.1: 18266, 0.5: 12100, 1: 9748, 5: 1912, 10: 810}},
    "bucky129": {"uniform": {0.1: 9276978, 0.5: 2792664, 1: 1352728, 5: 247760, 10: 95400},
                 "box": {0.1: 405860, 0.5: 190936, 1: 102430, 5: 23108, 10: 10382}},
}
SEED_4D = {
    "bucky4d": {"uniform": {0: (2419152, 196608), 1: (1384610, 114268), 5: (772086, 60968),
                            10: (493358, 36502)},
                "box": {0: (421072, 34912), 1: (207194, 16986), 5: (102736, 8510),
                        10: (66718, 5878)},
                "iso": {0: (1139996, 87300), 1: (975740, 78538), 5: (712942, 55944),
                        10: (492180, 36422)}},
}

# Format 1's figures (one error per simplex in subtree bands, the stores
# before 2026-11-26), for comparison: bytes per grid point measured by
# bench/format2_sizes.py on 2026-11-25 (bench/README.md), the scale run and
# the in-core rates from this script's run of 2026-11-21 (SimplexDB 1d0bd55).
FORMAT1_BYTES_PER_POINT = {"bucky32": 0.439, "neghip": 2.490, "headsq": 7.040, "tooth": 4.955,
                           "lidc2": 1.774, "fmri_4d": 35.807, "dwi_4d": 276.068}
FORMAT1_SCALE = {65: {"file_mib": 1.7, "splits_per_second": 9.52e6, "blocks_read": 28062},
                 257: {"file_mib": 50.3, "splits_per_second": 3.88e6, "blocks_read": 750441},
                 1025: {"file_mib": 1631.5, "splits_per_second": 0.14e6, "blocks_read": 3291221}}
FORMAT1_IN_CORE = {"ht129": 16.85e6, "hp33": 11.95e6}
FORMAT1_IN_MEMORY_SPLITS = {  # splits/s by algorithm, the same benchmark on format 1
    "ht129": {"depth-first": 16.85e6, "priority": 2.73e6, "incremental": 4.20e6, "saturated": 9.10e6},
    "hp33": {"depth-first": 11.95e6, "priority": 1.64e6, "incremental": 2.15e6, "saturated": 11.21e6}}


def log(msg):
    print(f"[{time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


def run(args, **kw):
    return subprocess.run(args, check=True, text=True, capture_output=True, **kw).stdout


def sdb(*args):
    return run([SIMPLEXDB, *map(str, args)])


def ensure_tools():
    missing = [p for p, pkg in (("/usr/bin/gnuplot", "gnuplot-nox"),) if not os.path.exists(p)]
    try:
        import vtkmodules  # noqa: F401
    except ImportError:
        missing.append("python3-vtk9")
    pkgs = ["gnuplot-nox" if m == "/usr/bin/gnuplot" else m for m in missing]
    if pkgs:
        if os.geteuid() != 0:
            sys.exit(f"experiments: needs {' '.join(pkgs)} (apt-get install {' '.join(pkgs)})")
        log(f"installing {' '.join(pkgs)}")
        subprocess.run(["apt-get", "install", "-y", "-qq", "--no-install-recommends", *pkgs],
                       check=True, stdout=subprocess.DEVNULL)
    if not (os.path.exists(SIMPLEXDB) and os.path.exists(QUERY_BENCH)):
        log("building the release preset")
        subprocess.run(["cmake", "--preset", "release"], cwd=ROOT, check=True, stdout=subprocess.DEVNULL)
        subprocess.run(["cmake", "--build", "--preset", "release"], cwd=ROOT, check=True)


class DataSet:
    """A volume, how to make it, its store, and where its queries look."""

    def __init__(self, name, description, make, dimension, seed_name=None):
        self.name, self.description, self.make = name, description, make
        self.dimension, self.seed_name = dimension, seed_name

    def prepare(self, work):
        self.store = os.path.join(work, self.name + ".sdb")
        if not os.path.exists(self.store):
            log(f"{self.name}: importing")
            self.make(work, self.store)
        self.info = json.loads(sdb("info", self.store, "--json"))
        dims = self.info["dims"][:self.dimension]
        self.dims = dims
        lo, hi = self.info["field_min"], self.info["field_max"]
        # The isovalue: 40 % up the field range (100 on the Buckyball's 0..254,
        # the seed's isovalue there).
        self.iso = lo + 0.4 * (hi - lo)
        # The box: from a quarter to a half of every spatial axis, an eighth of
        # each axis wide (1/64 of a 3D volume), off-centre so that it meets
        # the Buckyball's cage; the 4D box spans all of time.
        box = [(d - 1) / 4 for d in dims[:3]] + [(d - 1) / 2 for d in dims[:3]]
        if self.dimension == 4:
            box += [0, dims[3] - 1]
        self.box = ",".join(f"{v:g}" for v in box)
        self.time = min(4, dims[3] - 1) if self.dimension == 4 else None
        return self


def generated(field, dims, extra=()):
    def make(work, store):
        nrrd = store[:-4] + ".nrrd"
        sdb("generate", "--field", field, "--dims", dims, "--type", "uint8", "-q", "-o", nrrd, *extra)
        sdb("import", nrrd, "-o", store, "-q")
    return make


def from_raw(path, dims, vtype):
    def make(work, store):
        sdb("import", path, "--dims", dims, "--type", vtype, "-o", store, "-q")
    return make


def from_file(path):
    def make(work, store):
        sdb("import", path, "-o", store, "-q")
    return make


def bucky4d(work, store):
    bucky = os.path.join(work, "bucky129.nrrd")
    if not os.path.exists(bucky):
        sdb("generate", "--field", "buckyball", "--dims", "129,129,129", "--type", "uint8", "-q", "-o", bucky)
    nrrd = store[:-4] + ".nrrd"
    sdb("to4d", bucky, "-o", nrrd, "-q")
    sdb("import", nrrd, "-o", store, "-q")


def data_sets(work):
    sets = [
        DataSet("plasma64", "65^3 Perlin noise (the seed's Plasma64)",
                generated("perlin", "65,65,65"), 3, "Plasma64"),
        DataSet("bucky129", "129^3 C60 density (the seed's Buckyball)",
                generated("buckyball", "129,129,129"), 3, "Buckyball"),
    ]
    real3 = [("bucky32", "bucky/bucky_32x32x32_uint8.raw", "32,32,32", "uint8", "C60, real, 32^3"),
             ("neghip", "neghip/neghip_64x64x64_uint8.raw", "64,64,64", "uint8", "protein potential, 64^3"),
             ("headsq", "headsq/headsq_64x64x93_int16le.raw", "64,64,93", "int16", "CT head, 64x64x93"),
             ("tooth", "tooth/tooth_103x94x161_uint8.raw", "103,94,161", "uint8", "CT tooth, 103x94x161"),
             ("lidc2", "lidc2/LIDC2_256x256x133_uint8.raw", "256,256,133", "uint8", "chest CT, 256x256x133")]
    for name, rel, dims, vtype, what in real3:
        path = os.path.join(DATA, rel)
        if os.path.exists(path):
            sets.append(DataSet(name, what + " (../shared/data)", from_raw(path, dims, vtype), 3))
    sets += [
        DataSet("bucky4d", "33^4 from the 129^3 Buckyball, 4x4x4 subgrids as time (seed 4.7)",
                bucky4d, 4, "modified Buckyball"),
        DataSet("perlin33_4d", "33^4 Perlin noise (in place of the seed's Richtmyer-Meshkov subset)",
                generated("perlin", "33,33,33,33"), 4),
    ]
    for name, rel, what in [("fmri_4d", "fmri_example4d/example4d.nii", "fMRI, 128x96x24x2"),
                            ("dwi_4d", "dwi_small_101D/small_101D.nii", "diffusion MRI, 6x10x10x102")]:
        path = os.path.join(DATA, rel)
        if os.path.exists(path):
            sets.append(DataSet(name, what + " (../shared/data)", from_file(path), 4))
    return [s.prepare(work) for s in sets]


def extract(ds, pct, criterion, algorithm="depth-first", time_slice=True, extra=()):
    args = ["extract", ds.store, "--error", f"{pct:g}%", "--algorithm", algorithm, *extra]
    if criterion == "box":
        args += ["--box", ds.box]
    elif criterion == "iso":
        args += ["--iso", f"{ds.iso:g}"]
    if ds.dimension == 4 and time_slice:
        args += ["--time", str(ds.time)]
    return json.loads(sdb(*args))


def mesh_sizes(sets):
    results = {}
    for ds in sets:
        log(f"{ds.name}: mesh sizes")
        r = results[ds.name] = {}
        for criterion in ("uniform", "box", "iso"):
            r[criterion] = {p: extract(ds, p, criterion) for p in THRESHOLDS}
        # Saturation against ours over the whole domain (no time slice; in 3D
        # that is the uniform query already run).
        r["whole"] = r["uniform"] if ds.dimension == 3 else {
            p: extract(ds, p, "uniform", time_slice=False) for p in THRESHOLDS}
        r["saturated"] = {p: saturated(ds, p) for p in THRESHOLDS}
    return results


def saturated(ds, pct):
    """None where the tool refuses: saturation visits every internal node,
    which it does not attempt past 2^32 (the padded 4D volumes)."""
    try:
        return extract(ds, pct, "uniform", "saturated", time_slice=False)
    except subprocess.CalledProcessError as e:
        if "visits every internal node" not in e.stderr:
            raise
        return None


def fmt_int(n):
    return f"{int(n):,}"


def pct_of(n, full):
    p = 100.0 * n / full
    return f"{p:.2f}%" if p < 1 else f"{p:.1f}%"


def table(header, rows):
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def mesh_tables_3d(sets, results):
    out = []
    for ds in (d for d in sets if d.dimension == 3):
        r = results[ds.name]
        full = r["uniform"][0]["full_resolution_simplices"]
        seed = SEED_3D.get(ds.name, {})
        header = ["error (% of range)"]
        for c, title in (("uniform", "uniform"), ("box", "box"), ("iso", f"isovalue {ds.iso:g}")):
            header += [title, "%"]
            if c in seed:
                header += [f"seed {c}", "%"]
        rows = []
        for p in THRESHOLDS:
            row = [f"{p:g}"]
            for c in ("uniform", "box", "iso"):
                n = r[c][p]["simplices"]
                row += [fmt_int(n), pct_of(n, full)]
                if c in seed:
                    s = seed[c].get(p)
                    row += [fmt_int(s), pct_of(s, full)] if s is not None else ["-", "-"]
            rows.append(row)
        out.append(f"#### {ds.name}: {ds.description}\n\n"
                   f"{fmt_int(full)} tetrahedra at full resolution; box {ds.box} (grid units).\n\n"
                   + table(header, rows))
    return "\n\n".join(out)


def mesh_tables_4d(sets, results):
    out = []
    for ds in (d for d in sets if d.dimension == 4):
        r = results[ds.name]
        full = r["uniform"][0]["full_resolution_simplices"]
        full_slice = r["uniform"][0].get("full_resolution_slice_tetrahedra")
        seed = SEED_4D.get(ds.name, {})
        header = ["query", "error (% of range)", "pentatopes", "%", "slice tetrahedra", "%"]
        if seed:
            header += ["seed pentatopes", "seed slice tetrahedra"]
        rows = []
        for c, title in (("uniform", "uniform"), ("box", "box"), ("iso", f"isovalue {ds.iso:g}")):
            for p in THRESHOLDS:
                q = r[c][p]
                row = [title, f"{p:g}", fmt_int(q["simplices"]), pct_of(q["simplices"], full),
                       fmt_int(q["slice_tetrahedra"]),
                       pct_of(q["slice_tetrahedra"], full_slice) if full_slice else "-"]
                if seed:
                    s = seed.get(c, {}).get(p)
                    row += [fmt_int(s[0]), fmt_int(s[1])] if s else ["-", "-"]
                rows.append(row)
        out.append(f"#### {ds.name}: {ds.description}\n\n"
                   f"{fmt_int(full)} pentatopes at full resolution; every query held to the time "
                   f"slice t = {ds.time} (grid units), whose full-resolution cut has "
                   f"{fmt_int(full_slice or 0)} tetrahedra; box {ds.box}.\n\n" + table(header, rows))
    return "\n\n".join(out)


def saturation_table(sets, results):
    rows = []
    for ds in sets:
        r = results[ds.name]
        ratios = []
        cells = [ds.name, "HT" if ds.dimension == 3 else "HP"]
        if r["saturated"][0] is None:
            rows.append(cells + ["not run: more than 2^32 internal nodes to saturate"] +
                        [""] * len(THRESHOLDS))
            continue
        for p in THRESHOLDS:
            ours, sat = r["whole"][p]["simplices"], r["saturated"][p]["simplices"]
            ratio = sat / ours if ours else 1.0
            ratios.append(ratio)
            cells.append(f"{100 * (ratio - 1):+.1f}%")
        cells.append(f"{100 * (sum(ratios) / len(ratios) - 1):+.1f}%")
        rows.append(cells)
    return table(["data set", "hierarchy"] + [f"{p:g}%" for p in THRESHOLDS] + ["mean"], rows)


def query_bench(work, quick):
    out = os.path.join(work, "query_bench.json")
    # No cache at all is the floor; its slow priority and incremental runs
    # (minutes for the HP) add nothing to the ratio, so only depth-first.
    flt = "Extract/(ht129|hp33)/(in-memory|raw|zstd-warm|zstd-cold|lmdb)/.*|Extract/.*/zstd-nocache/depth-first"
    log("query_bench (Fig. 46): every store and algorithm")
    env = dict(os.environ, TMPDIR=work)
    # This machine's speed drifts within minutes (the benchmark context has
    # read 2096 and 2445 MHz on the same day): stores run one after another
    # once each measured the drift, not the store. So three repetitions of
    # each, interleaved at random, and the median.
    subprocess.run([QUERY_BENCH, f"--benchmark_filter={flt}", "--benchmark_format=json",
                    f"--benchmark_out={out}", "--benchmark_out_format=json",
                    f"--benchmark_min_time={0.2 if quick else 0.5}",
                    "--benchmark_repetitions=3", "--benchmark_enable_random_interleaving=true",
                    "--benchmark_report_aggregates_only=true"],
                   check=True, stdout=subprocess.DEVNULL, env=env)
    with open(out) as f:
        bench = json.load(f)
    rates = {}
    for b in bench["benchmarks"]:
        if b.get("aggregate_name") != "median":
            continue
        _, hierarchy, store, algorithm = b["name"].split("/")[:4]
        rates[(hierarchy, store, algorithm)] = b
    return rates, bench["context"]


STORES = ["in-memory", "raw", "zstd-warm", "zstd-cold", "zstd-nocache", "lmdb"]
ALGORITHMS = ["depth-first", "priority", "incremental", "saturated"]


def fig46_tables(rates):
    out = []
    for hierarchy, title in (("ht129", "HT, 129^3 Perlin noise"), ("hp33", "HP, 33^4 Perlin noise")):
        rows = []
        for algorithm in ALGORITHMS:
            base = rates.get((hierarchy, "in-memory", algorithm))
            for counter, label in (("splits/s", "splits/s"), ("clusters/s", "clusters/s"),
                                   ("merges/s", "merges/s")):
                if base is None or counter not in base:
                    continue
                row = [algorithm, label]
                for store in STORES:
                    b = rates.get((hierarchy, store, algorithm))
                    if b is None:
                        row.append("-")
                        continue
                    v = b[counter]
                    row.append(f"{v / 1e6:.2f} M ({v / base[counter]:.2f})")
                old = FORMAT1_IN_MEMORY_SPLITS[hierarchy].get(algorithm) if counter == "splits/s" else None
                row.append(f"{old / 1e6:.2f} M" if old else "")
                rows.append(row)
        out.append(f"#### {title}\n\n" +
                   table(["algorithm", "rate"] + STORES + ["in-memory, format 1"], rows))
    return "\n\n".join(out)


def scale_runs(work, quick):
    sides = [65, 257] if quick else [65, 257, 1025]
    rows = []
    for side in sides:
        store = os.path.join(work, f"perlin{side}.sdb")
        nrrd = os.path.join(work, f"perlin{side}.nrrd")
        if not os.path.exists(nrrd):
            log(f"scale: generating {side}^3")
            sdb("generate", "--field", "perlin", "--dims", f"{side},{side},{side}", "--type", "uint8",
                "-q", "-o", nrrd)
        # Built every run: the build rate is one of the figures. The field
        # (a byte a point) and the diamond table: 1.6 GiB at 1025^3.
        log(f"scale: importing {side}^3")
        build = json.loads(sdb("import", nrrd, "-o", store, "--force", "--json", "--memory-mb", "6144"))
        info = json.loads(sdb("info", store, "--json"))
        log(f"scale: querying {side}^3")
        r = json.loads(sdb("extract", store, "--error", "1%", "--cache-mb", "256"))
        rows.append({"side": side, "info": info, "build": build, "query": r})
    return rows


def scale_table(rows):
    body = []
    for row in rows:
        info, q, b = row["info"], row["query"], row["build"]
        anon = q["anonymous_memory_bytes"]
        old = FORMAT1_SCALE.get(row["side"])
        body.append([f"{row['side']}^3", f"{b['seconds']:.1f}",
                     f"{b['grid_points_per_second'] / 1e6:.1f} M",
                     f"{b['peak_memory_bytes'] / 2**20:,.0f} MiB",
                     f"{info['file_bytes'] / 2**20:,.1f} MiB" +
                     (f" ({old['file_mib']:,.1f})" if old else ""),
                     f"{info['logical_bytes'] / 2**20:,.0f} MiB", fmt_int(q["simplices"]),
                     f"{q['seconds']:.2f}",
                     f"{q['splits_per_second'] / 1e6:.2f} M" +
                     (f" ({old['splits_per_second'] / 1e6:.2f} M)" if old else ""),
                     fmt_int(q["blocks_read"]) + (f" ({fmt_int(old['blocks_read'])})" if old else ""),
                     f"{q['cache_bytes'] / 2**20:,.0f} MiB",
                     f"{anon / 2**20:,.0f} MiB",
                     f"{(anon - q['cache_bytes']) / max(q['simplices'], 1):.0f} B",
                     f"{q['peak_memory_bytes'] / 2**20:,.0f} MiB"])
    return table(["store", "build s", "build points/s", "build peak memory",
                  "on disk (format 1)", "logical (decoded)", "tetrahedra in the mesh",
                  "query s", "splits/s (format 1)", "blocks read (format 1)", "cache held",
                  "anonymous memory", "(anonymous - cache) / tetrahedron",
                  "peak resident (with file pages)"], body)


def sizes_table(sets):
    rows = []
    for d in sets:
        info = d.info
        points = info["grid_points"]
        old = FORMAT1_BYTES_PER_POINT.get(d.name)
        ours = info["file_bytes"] / points
        rows.append([d.name, "HT" if d.dimension == 3 else "HP", fmt_int(points),
                     f"{info['file_bytes'] / 2**20:,.2f} MiB", f"{ours:.3f}",
                     f"{info['field_bytes'] / points:.3f}", f"{info['error_bytes'] / points:.3f}",
                     f"{old:.3f}" if old else "-", f"{ours / old:.2f}" if old else "-"])
    return table(["data set", "hierarchy", "grid points", "store", "bytes / point",
                  "field bricks", "error blocks", "format 1", "format 2 / format 1"], rows)


def gnuplot(script):
    subprocess.run(["gnuplot"], input=script, text=True, check=True)


def plot_mesh_sizes(sets, results):
    paths = []
    for dim, what in ((3, "tetrahedra"), (4, "pentatopes")):
        dat = os.path.join(OUT_DIR, f"mesh_size_{dim}d.dat")
        chosen = [d for d in sets if d.dimension == dim]
        with open(dat, "w") as f:
            for ds in chosen:
                f.write(f'"{ds.name}"\n')
                full = results[ds.name]["whole"][0]["full_resolution_simplices"]
                for p in THRESHOLDS[1:]:
                    f.write(f"{p} {100 * results[ds.name]['whole'][p]['simplices'] / full}\n")
                f.write("\n\n")
        svg = os.path.join(OUT_DIR, f"mesh_size_{dim}d.svg")
        plots = ", ".join(f"'{dat}' index {i} with linespoints lw 2 title columnheader(1)"
                          for i in range(len(chosen)))
        gnuplot(f"""set terminal svg size 640,420 font 'sans,11' background '#ffffff'
set output '{svg}'
set logscale xy
set xlabel 'error threshold (% of the field range)'
set ylabel '{what} (% of full resolution)'
set title 'Uniform queries, {dim}D: mesh size against threshold'
set key outside right
set grid
plot {plots}
""")
        os.remove(dat)
        paths.append(svg)
    return paths


def plot_throughput(rates):
    svg = os.path.join(OUT_DIR, "throughput.svg")
    dat = os.path.join(OUT_DIR, "throughput.dat")
    with open(dat, "w") as f:
        for store in STORES:
            cells = []
            for a in ALGORITHMS:
                for h in ("ht129", "hp33"):
                    b, base = rates.get((h, store, a)), rates.get((h, "in-memory", a))
                    cells.append(f"{b['splits/s'] / base['splits/s']:.4f}" if b and base else "NaN")
            f.write(f"{store} " + " ".join(cells) + "\n")
    cols = " , ".join(f"'' using {i + 2} title '{'HT' if i % 2 == 0 else 'HP'} {ALGORITHMS[i // 2]}'"
                      for i in range(1, 2 * len(ALGORITHMS)))
    gnuplot(f"""set terminal svg size 760,420 font 'sans,11' background '#ffffff'
set output '{svg}'
set style data histograms
set style histogram clustered gap 1
set style fill solid 0.8 border -1
set logscale y
set yrange [0.01:2]
set ylabel 'splits/s, ratio to in-memory (log)'
set title 'Selective refinement per store (Fig. 46): ratio to in-core, same run'
set key outside right
set grid ytics
set xtics rotate by -25
plot '{dat}' using 2:xtic(1) title 'HT {ALGORITHMS[0]}', {cols}
""")
    os.remove(dat)
    return svg


SLICE_SCRIPT = os.path.join(ROOT, "bench", "slice_svg.py")


def slices(sets, work):
    """Meshes cut by a plane and drawn as SVG: 3D Buckyball and 4D slice."""
    pictures = []
    by_name = {d.name: d for d in sets}
    jobs = []
    if "bucky129" in by_name:
        ds = by_name["bucky129"]
        jobs += [(ds, "uniform", 5, "uniform LOD, 5 % of the range (cf. Fig. 47a)"),
                 (ds, "box", 1, "1 % inside the box, anything elsewhere (cf. Fig. 58)"),
                 (ds, "iso", 1, f"1 % on tetrahedra that may hold the isovalue {ds.iso:g} (cf. Fig. 47b)")]
    if "bucky4d" in by_name:
        ds = by_name["bucky4d"]
        jobs += [(ds, "uniform", 1, "4D, uniform 1 %, the time slice t = 4 (cf. Fig. 57)"),
                 (ds, "iso", 1, f"4D, 1 % near the isovalue {ds.iso:g}, time slice t = 4 (cf. Fig. 59)")]
    for ds, criterion, pct, caption in jobs:
        vtu = os.path.join(work, f"{ds.name}_{criterion}_{pct}.vtu")
        args = ["--format", "vtu", "-o", vtu]
        stats = extract(ds, pct, criterion, extra=args)
        svg = os.path.join(OUT_DIR, f"slice_{ds.name}_{criterion}.svg")
        z = (ds.dims[2] - 1) / 2
        run([sys.executable, SLICE_SCRIPT, vtu, svg, "--z", f"{z:g}",
             "--title", f"{ds.name}: {caption}; cut at z = {z:g}"])
        n = stats.get("slice_tetrahedra", stats["simplices"])
        pictures.append((svg, f"{ds.name}, {caption}: {fmt_int(n)} tetrahedra, cut at z = {z:g}"))
    return pictures


def machine():
    cpu = "unknown CPU"
    with open("/proc/cpuinfo") as f:
        for line in f:
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    with open("/proc/meminfo") as f:
        mem_kb = int(f.readline().split()[1])
    compiler = run(["c++", "--version"]).splitlines()[0]
    commit = run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"]).strip()
    dirty = run(["git", "-C", ROOT, "status", "--porcelain", "--untracked-files=no"]).strip()
    return (f"{cpu}, {os.cpu_count()} cores, {mem_kb / 2**20:.1f} GiB; {platform.system()} "
            f"{platform.release()}; {compiler}; SimplexDB {commit}{' (with local changes)' if dirty else ''}, "
            f"build/release (RelWithDebInfo)")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="shorter benchmark runs, no 1025^3 store")
    ap.add_argument("--work", default="/tmp/simplexdb-experiments", help="volumes and stores (reused)")
    a = ap.parse_args()
    started = time.time()
    ensure_tools()
    os.makedirs(a.work, exist_ok=True)
    os.makedirs(OUT_DIR, exist_ok=True)
    sets = data_sets(a.work)
    results = mesh_sizes(sets)
    pictures = slices(sets, a.work)
    rates, context = query_bench(a.work, a.quick)
    scale = scale_runs(a.work, a.quick)
    plots = plot_mesh_sizes(sets, results) + [plot_throughput(rates)]
    with open(os.path.join(a.work, "results.json"), "w") as f:
        json.dump({"mesh_sizes": {k: {c: {str(p): q for p, q in v.items()} for c, v in r.items()}
                                  for k, r in results.items()},
                   "scale": scale}, f)
    write_results(sets, results, rates, context, scale, plots, pictures, a, time.time() - started)
    log(f"wrote {os.path.join(ROOT, 'bench', 'RESULTS.md')}")


def rel(path):
    return os.path.relpath(path, os.path.join(ROOT, "bench"))


def summary(sets, results, rates, scale):
    """The run's headline numbers, computed (not typed) for the top of RESULTS.md."""
    lines = []
    df = {h: rates.get((h, "in-memory", "depth-first")) for h in ("ht129", "hp33")}
    if df["ht129"]:
        lines.append(f"- In core, depth-first refinement splits {df['ht129']['splits/s'] / 1e6:.1f} M "
                     f"tetrahedra and {df['hp33']['splits/s'] / 1e6:.1f} M pentatopes a second "
                     f"(format 1: {FORMAT1_IN_CORE['ht129'] / 1e6:.1f} M and "
                     f"{FORMAT1_IN_CORE['hp33'] / 1e6:.1f} M); the seed measured about 0.28 M "
                     f"tetrahedra a second out of core.")
        cold = [rates.get((h, "zstd-cold", "depth-first")) for h in ("ht129", "hp33")]
        if all(cold):
            lines.append(f"- A compressed store read through a cache that starts empty keeps "
                         f"{cold[0]['splits/s'] / df['ht129']['splits/s']:.2f} (HT) and "
                         f"{cold[1]['splits/s'] / df['hp33']['splits/s']:.2f} (HP) of the in-core rate.")
    for dim, seed in ((3, "+5 %"), (4, "under +1 %")):
        excess = [100 * (r["saturated"][p]["simplices"] / r["whole"][p]["simplices"] - 1)
                  for ds in sets if ds.dimension == dim
                  for r in [results[ds.name]] if r["saturated"][0] is not None
                  for p in THRESHOLDS if r["whole"][p]["simplices"]]
        if excess:
            lines.append(f"- Saturation costs {sum(excess) / len(excess):+.1f} % simplices on average in "
                         f"{dim}D (at most {max(excess):+.1f} %); the seed found {seed}.")
    shrunk = [FORMAT1_BYTES_PER_POINT[d.name] / (d.info["file_bytes"] / d.info["grid_points"])
              for d in sets if d.name in FORMAT1_BYTES_PER_POINT]
    if shrunk:
        lines.append(f"- Stores are {min(shrunk):.1f}x to {max(shrunk):.0f}x smaller than format 1's on "
                     f"the real volumes.")
    if scale:
        big = scale[-1]
        old = FORMAT1_SCALE.get(big["side"])
        lines.append(f"- {big['side']}^3 builds at {big['build']['grid_points_per_second'] / 1e6:.1f} M "
                     f"grid points a second and is queried at "
                     f"{big['query']['splits_per_second'] / 1e6:.2f} M splits a second with a 256 MiB "
                     f"cache" + (f" (format 1: {old['splits_per_second'] / 1e6:.2f} M)" if old else "") +
                     ".")
        lines.append(f"- The largest store, {big['side']}^3 ({big['info']['logical_bytes'] / 2**30:.1f} GiB "
                     f"decoded), was queried with {big['query']['cache_bytes'] / 2**20:.0f} MiB of cache "
                     f"held and {big['query']['anonymous_memory_bytes'] / 2**20:.0f} MiB of anonymous "
                     f"memory in all (cache, mesh and query).")
    return "\n".join(lines)


def write_results(sets, results, rates, context, scale, plots, pictures, a, seconds):
    command = "bench/experiments.py" + (" --quick" if a.quick else "")
    ds_rows = [[d.name, "HT" if d.dimension == 3 else "HP", "x".join(map(str, d.dims)), d.description,
                fmt_int(d.info["grid_points"])] for d in sets]
    text = f"""# Results: the seed's experiments, rerun

Written by `{command}` on {datetime.date.today().isoformat()} in {seconds / 60:.0f} minutes; every
figure below comes from that run. Machine: {machine()}.

Rerun: `bench/experiments.py` (all of it) or `bench/experiments.py --quick` (no 1025^3 store, shorter
benchmark runs). Volumes and stores go to `--work` (default /tmp/simplexdb-experiments) and
are reused. Each query is a `simplexdb extract` call whose `--format json` statistics give
the counts; the throughput table is `build/release/bench/query_bench`.

{summary(sets, results, rates, scale)}

## Data sets

{table(["name", "hierarchy", "grid", "what", "grid points"], ds_rows)}

The seed's own volumes are not available, so its experiments run on stand-ins built the
way it describes them: Plasma64 is 65^3 Perlin noise (our generator, not Pisa's), the
Buckyball a model of C60's electron density at 129^3 (`simplexdb generate --field
buckyball`; a 32^3 copy of the real one is among the real volumes), the 4D Buckyball its
4x4x4 subgrids laid along time (`simplexdb to4d`, section 4.7), and 33^4 Perlin noise
takes the place of the Richtmyer-Meshkov subset. The counts therefore differ from the
seed's; what carries over is their shape: how fast a mesh shrinks with the threshold and
how much a box or an isovalue saves.

## Mesh sizes (Figs. 48, 49, 50)

Tetrahedra in the extracted mesh (depth-first; the minimal conforming mesh, so the other
algorithms give the same counts) and their share of the full-resolution mesh. The box and
the isovalue hold only the simplices they meet to the threshold; everything else may stay
as coarse as conformity allows. Where the seed reported a figure it stands beside ours.
The errors are format 2's: each simplex takes its diamond's error (the largest over the
simplices that share its split edge), so some meshes hold a few more simplices than with
format 1's per-simplex errors (the tables of 2026-11-21 in this file's history), never
fewer at a uniform threshold.

A threshold of 0 splits only simplices whose error exceeds 0: where the field is linear
(the empty space around the Buckyball, uniform regions of real scans) the mesh stays
coarse. The seed's 4D table shows 100 % of the slice at 0, so its criterion split at error
0 too; ours does not, which is why our 0 rows are below 100 % on data with uniform regions.

{mesh_tables_3d(sets, results)}

![mesh size against threshold, 3D]({rel(plots[0])})

## Mesh sizes in 4D (Figs. 63, 64)

Pentatopes in the 4D mesh and tetrahedra in its time slice. As in the seed every query is
held to the time slice (`--time`), so pentatopes away from it stay coarse.

{mesh_tables_4d(sets, results)}

![mesh size against threshold, 4D (whole domain)]({rel(plots[1])})

## Saturation (sections 3.7 and 4.7)

Simplices in the mesh extracted from the saturated hierarchy (`--algorithm saturated`:
errors raised to the maximum over each cluster and over the children, then a plain
top-down traversal) against ours, uniform queries over the whole domain. The seed found
about +5 % in 3D and under +1 % in 4D.

{saturation_table(sets, results)}

## Store sizes

Each data set's dense store (format 2: one error per diamond in hierarchical Z-order, u16
errors, zstd; the finest octave's errors are not stored but computed from the field) in
bytes per grid point, its field bricks and error blocks apart (`simplexdb info --json`),
beside format 1's (one error per simplex in subtree bands: measured by
`bench/format2_sizes.py` on 2026-11-25, real volumes only). The seed's layout with 16-bit
errors took 14 bytes per grid point in 3D. The field compressed alone by HDF5, Zarr and
`zstd -19` is in `bench/README.md`.

{sizes_table(sets)}

## Throughput per store (Fig. 46)

Splits (and cluster computations, merges) per second at 1 % of the range, each store as a
ratio to in-memory measured in the same run: in-memory (the zstd store decoded at open:
in-core), mapped raw blocks, zstd with a warm 1 GiB cache, zstd cold (opened anew before
each query: a 256 MiB cache that starts empty; the OS page cache may still hold the file),
zstd with no cache at all (the floor: depth-first only), and the lossless LMDB store.
Incremental goes from the 5 % mesh to the 1 % mesh and back. Perlin noise, as in
`bench/query_bench.cc`. The last column is format 1's in-memory rate in this script's run
of 2026-11-21 (another machine of this kind; that binary, rebuilt, ran at about 9 M splits/s
in the HT on 2026-11-27: `bench/in_core_vs_format1.sh` runs it and today's in turn). The
seed's Fig. 46 measured about 280,000 splits per second out of core (Pentium III, 650 MHz).

Benchmark context: {context.get('num_cpus')} CPUs at {context.get('mhz_per_cpu')} MHz,
`{os.path.relpath(QUERY_BENCH, ROOT)} --benchmark_min_time={0.2 if a.quick else 0.5} --benchmark_repetitions=3
--benchmark_enable_random_interleaving=true` (medians; filter in
`bench/experiments.py`).

{fig46_tables(rates)}

![throughput per store]({rel(plots[2])})

## Scale: a fixed cache budget as the store grows

The same query, uniform at 1 % of the range, depth-first, over HT stores of 8-bit Perlin
noise built with `simplexdb import --memory-mb 6144` (build seconds, rate and peak memory
from its `--json`), read with `--cache-mb 256`. Format 1's figures, in parentheses, are
those of this script's run of 2026-11-21 (its 1025^3 build took about 20 minutes). Anonymous memory
(`anonymous_memory_bytes`, RssAnon at the end of the query, the mesh still held) is what the
process allocated: the cache, which stays within its budget, plus the mesh and the query's
sets, which grow with the mesh, not with the store. Peak resident memory also counts the
pages of the memory-mapped store file the query touched; the kernel drops those under
pressure, so they are not a cost the budget has to bound.

{scale_table(scale)}

## Slices through extracted meshes (Figs. 47, 57-59)

Each picture is the mesh that `simplexdb extract --format vtu` wrote, read with VTK and cut
by the plane z = const (`bench/slice_svg.py`): every polygon is a tetrahedron's cut,
coloured by the interpolated field, so cell size shows where the query refined.

""" + "\n\n".join(f"![{cap}]({rel(p)})\n\n*{cap}*" for p, cap in pictures) + "\n"
    with open(os.path.join(ROOT, "bench", "RESULTS.md"), "w") as f:
        f.write(text)


if __name__ == "__main__":
    main()
