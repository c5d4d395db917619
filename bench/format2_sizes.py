#!/usr/bin/python3
"""Store sizes against the field alone, per volume (issue 16's size target).

For each volume in ../shared/data and a 257^3 Perlin volume, in bytes per
grid point:
  - peers, the field alone: `zstd -19` of the raw voxels; HDF5 with 64^3
    chunks (64^4 for 4D) and Blosc-zstd (level 5, byte shuffle) through
    h5py; Zarr with the same chunks and compressor;
  - ours: the dense store (format 2) `simplexdb import` writes with u16
    and u8 errors, and the u16 store's two parts as `info` reports them:
    the field's bricks and the error blocks (format 1's figures, before it
    was replaced, are in bench/README.md);
  - the ratio of format 2 (u16 and u8) to the smaller peer: the target is
    at most 2.0.

Run from the repository root after a release build:
    /usr/bin/python3 bench/format2_sizes.py [--work DIR] [--json OUT]
Needs Debian's python3-h5py, python3-hdf5plugin, hdf5-filter-plugin-blosc-
serial, python3-zarr, python3-numcodecs, python3-numpy and zstd; installs the
missing ones with apt-get when run as root.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "..", "shared", "data")
CLI = os.path.join(ROOT, "build", "release", "tools", "simplexdb")
PACKAGES = ["python3-h5py", "python3-hdf5plugin", "hdf5-filter-plugin-blosc-serial",
            "python3-zarr", "python3-numcodecs", "python3-numpy", "zstd"]

# name, file, dims (x fastest), numpy dtype, header bytes, import arguments
VOLUMES = [
    ("bucky", "bucky/bucky_32x32x32_uint8.raw", (32, 32, 32), "u1", 0,
     ["--dims", "32,32,32", "--type", "uint8"]),
    ("neghip", "neghip/neghip_64x64x64_uint8.raw", (64, 64, 64), "u1", 0,
     ["--dims", "64,64,64", "--type", "uint8"]),
    ("tooth", "tooth/tooth_103x94x161_uint8.raw", (103, 94, 161), "u1", 0,
     ["--dims", "103,94,161", "--type", "uint8"]),
    ("headsq", "headsq/headsq_64x64x93_int16le.raw", (64, 64, 93), "<i2", 0,
     ["--dims", "64,64,93", "--type", "int16"]),
    ("lidc2", "lidc2/LIDC2_256x256x133_uint8.raw", (256, 256, 133), "u1", 0,
     ["--dims", "256,256,133", "--type", "uint8"]),
    ("fmri (4D)", "fmri_example4d/example4d.nii", (128, 96, 24, 2), "<i2", 416, []),
    ("dwi (4D)", "dwi_small_101D/small_101D.nii", (6, 10, 10, 102), "<u2", 352, []),
]


def ensure_packages():
    try:
        import h5py, hdf5plugin, numcodecs, numpy, zarr  # noqa: F401
        if shutil.which("zstd"):
            return
    except ImportError:
        pass
    if os.geteuid() != 0:
        sys.exit("format2_sizes: needs " + " ".join(PACKAGES))
    subprocess.run(["apt-get", "install", "-y", "-qq", "--no-install-recommends", *PACKAGES],
                   check=True, stdout=subprocess.DEVNULL)


def run(*args, env=None):
    return subprocess.run(args, check=True, capture_output=True, text=True, env=env).stdout


def folder_bytes(path):
    return sum(os.path.getsize(os.path.join(d, f)) for d, _, files in os.walk(path) for f in files)


def peers(values, work):
    import h5py
    import hdf5plugin
    import numcodecs
    import zarr
    raw = os.path.join(work, "field.raw")
    values.tofile(raw)
    z19 = len(subprocess.run(["zstd", "-19", "-q", "-c", raw], check=True,
                             capture_output=True).stdout)
    array = values  # z, y, x (t first in 4D): x fastest on disk
    chunks = tuple(min(64, n) for n in array.shape)
    h5 = os.path.join(work, "field.h5")
    with h5py.File(h5, "w") as f:
        f.create_dataset("v", data=array, chunks=chunks,
                         **hdf5plugin.Blosc(cname="zstd", clevel=5,
                                            shuffle=hdf5plugin.Blosc.SHUFFLE))
    zpath = os.path.join(work, "field.zarr")
    z = zarr.open(zpath, mode="w", shape=array.shape, chunks=chunks, dtype=array.dtype,
                  compressor=numcodecs.Blosc(cname="zstd", clevel=5,
                                             shuffle=numcodecs.Blosc.SHUFFLE))
    z[:] = array
    return {"zstd19": z19, "hdf5": os.path.getsize(h5), "zarr": folder_bytes(zpath)}


def ours(source_args, work):
    out = {}
    for q in ("u16", "u8"):
        store = os.path.join(work, f"f2_{q}.sdb")
        run(CLI, "import", *source_args, "--quantization", q, "-o", store, "-q", "--force")
        out[f"format2_{q}"] = os.path.getsize(store)
        if q == "u16":
            info = json.loads(run(CLI, "info", store, "--json"))
            out["f2_field"] = info["field_bytes"]
            out["f2_errors_u16"] = info["error_bytes"]
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--work", help="scratch folder (default: a temporary one)")
    parser.add_argument("--json", help="also write the figures as JSON here")
    args = parser.parse_args()
    ensure_packages()
    import numpy as np
    for tool in (CLI,):
        if not os.path.exists(tool):
            sys.exit(f"format2_sizes: {tool} is missing: build the release preset first")
    work = args.work or tempfile.mkdtemp(prefix="simplexdb_sizes_")
    os.makedirs(work, exist_ok=True)
    volumes = list(VOLUMES)
    perlin = os.path.join(work, "perlin257.nrrd")
    run(CLI, "generate", "--field", "perlin", "--dims", "257,257,257", "--type", "uint8",
        "-o", perlin, "-q", "--force")
    rows = []
    for name, rel, dims, dtype, skip, import_args in volumes + [
            ("perlin 257^3", None, (257, 257, 257), "u1", None, [])]:
        if rel is None:
            # The generated NRRD: its voxels are the file's last bytes.
            n = 257 ** 3
            values = np.fromfile(perlin, dtype="u1")[-n:]
            source = [perlin]
        else:
            path = os.path.join(DATA, rel)
            count = int(np.prod(dims))
            values = np.fromfile(path, dtype=dtype, count=count, offset=skip)
            source = [path] + import_args
        points = int(np.prod(dims))
        values = values.reshape(tuple(reversed(dims)))
        row = {"volume": name, "points": points, "raw": values.nbytes}
        row.update(peers(values, work))
        row.update(ours(source, work))
        best = min(row["zstd19"], row["hdf5"])
        row["ratio_u16"] = row["format2_u16"] / best
        row["ratio_u8"] = row["format2_u8"] / best
        rows.append(row)
        print(f"{name}: done", file=sys.stderr)
    cols = ["zstd19", "hdf5", "zarr", "format2_u16", "format2_u8", "f2_field",
            "f2_errors_u16"]
    print("| volume | points | " + " | ".join(cols) + " | f2 u16 / peer | f2 u8 / peer |")
    print("|---|---:|" + "---:|" * (len(cols) + 2))
    for r in rows:
        cells = [f"{r[c] / r['points']:.3f}" for c in cols]
        print(f"| {r['volume']} | {r['points']:,} | " + " | ".join(cells) +
              f" | {r['ratio_u16']:.2f} | {r['ratio_u8']:.2f} |")
    print("\nBytes per grid point; peer = the smaller of zstd -19 and HDF5.")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)
    if not args.work:
        shutil.rmtree(work)


if __name__ == "__main__":
    main()
