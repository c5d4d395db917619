#!/usr/bin/python3
"""Store sizes against the field alone, per volume (issue 16's size target).

For each volume in ../shared/data and a 257^3 Perlin volume, in bytes per
grid point:
  - peers, the field alone: `zstd -19` of the raw voxels; HDF5 with 64^3
    chunks (64^4 for 4D) and Blosc-zstd (level 5, byte shuffle) through
    h5py; Zarr with the same chunks and compressor;
  - ours: the format-1 store `simplexdb import` writes today; format 2
    (through a format-1 store with float32 errors and bench's hz_convert)
    with u16 and u8 errors; format 2's blocks holding the field alone
    (every error 0: what the errors cost is the difference);
  - the ratio of format 2 (u16 and u8) to the smaller peer: the target is
    at most 2.0;
  - the next layout's parts (docs/format/dense-store-2.md, "The next
    layout"): the field as bricks of every octave's lattice, each brick zstd
    with or without the Lorenzo predictor, whichever is smaller
    (bench/field_bricks); the errors of every octave but the finest, in
    format 2's blocks with the field left out (zstd level 3 per block, as
    the writer does; u16 and u8); their sum with 40 bytes of index per
    brick and block, and its ratio to the peer.

Run from the repository root after a release build:
    /usr/bin/python3 bench/format2_sizes.py [--work DIR] [--json OUT]
Needs Debian's python3-h5py, python3-hdf5plugin, hdf5-filter-plugin-blosc-
serial, python3-zarr, python3-numcodecs, python3-numpy, python3-zstandard and
zstd; installs the missing ones with apt-get when run as root.
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
CONVERT = os.path.join(ROOT, "build", "release", "bench", "hz_convert")
BRICKS = os.path.join(ROOT, "build", "release", "bench", "field_bricks")
PACKAGES = ["python3-h5py", "python3-hdf5plugin", "hdf5-filter-plugin-blosc-serial",
            "python3-zarr", "python3-numcodecs", "python3-numpy", "python3-zstandard", "zstd"]
INDEX_ENTRY = 40

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
        import h5py, hdf5plugin, numcodecs, numpy, zarr, zstandard  # noqa: F401
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


def coarse_errors(store):
    """Bytes of a format-2 store's error entries for every octave but the
    finest (HZ positions below 2^(D k)), zstd level 3 per block, and the
    number of those blocks."""
    import numpy as np
    import struct
    import zstandard
    b = open(store, "rb").read()
    dimension, quantization, k, block_bits = b[16], b[17], b[19], b[20]
    virtual, stored, bitmap_offset, index_offset = struct.unpack_from("<4Q", b, 152)
    words = np.frombuffer(b, dtype="<u8", count=(virtual + 63) // 64, offset=bitmap_offset)
    present = np.nonzero(np.unpackbits(words.view(np.uint8), bitorder="little")[:virtual])[0]
    width = {1: 2, 2: 1, 3: 4}[quantization]
    coarse_blocks = max(1, (1 << (dimension * k)) >> block_bits)
    unpack = zstandard.ZstdDecompressor()
    pack = zstandard.ZstdCompressor(level=3)
    total = blocks = 0
    for i, block in enumerate(present):
        if block >= coarse_blocks:
            break
        offset, size, encoding = struct.unpack_from("<QIB", b, index_offset + 40 * i)
        data = b[offset:offset + size]
        if encoding == 2:
            data = unpack.decompress(data, max_output_size=1 << 26)
        total += len(pack.compress(data[:width << block_bits]))
        blocks += 1
    return total, blocks


def ours(source_args, work):
    f1 = os.path.join(work, "f1.sdb")
    run(CLI, "import", *source_args, "-o", f1, "-q", "--force")
    out = {"format1": os.path.getsize(f1)}
    exact = os.path.join(work, "f1_f32.sdb")
    run(CLI, "import", *source_args, "--quantization", "f32", "--compression", "none",
        "-o", exact, "-q", "--force")
    for q in ("u16", "u8"):
        store = os.path.join(work, f"f2_{q}.sdb")
        report = json.loads(run(CONVERT, exact, store, q))
        out[f"format2_{q}"] = report["bytes"]
        out[f"coarse_errors_{q}"], out[f"coarse_blocks_{q}"] = coarse_errors(store)
    bricks = json.loads(run(BRICKS, *source_args))
    out["field_pyramid"] = round(bricks["pyramid_best_bpp"] * bricks["points"])
    out["pyramid_bricks"] = bricks["pyramid_bricks"]
    for q in ("u16", "u8"):
        out[f"next_{q}"] = (4096 + out["field_pyramid"] + out[f"coarse_errors_{q}"] +
                            INDEX_ENTRY * (out["pyramid_bricks"] + out[f"coarse_blocks_{q}"]))
    env = dict(os.environ, SIMPLEXDB_HZ_FIELD_ONLY="1")
    report = json.loads(run(CONVERT, exact, os.path.join(work, "f2_field.sdb"), "u16", env=env))
    out["format2_field_only"] = report["bytes"]
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--work", help="scratch folder (default: a temporary one)")
    parser.add_argument("--json", help="also write the figures as JSON here")
    args = parser.parse_args()
    ensure_packages()
    import numpy as np
    for tool in (CLI, CONVERT, BRICKS):
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
        row["ratio_next_u16"] = row["next_u16"] / best
        row["ratio_next_u8"] = row["next_u8"] / best
        rows.append(row)
        print(f"{name}: done", file=sys.stderr)
    cols = ["zstd19", "hdf5", "zarr", "format1", "format2_u16", "format2_u8", "format2_field_only"]
    print("| volume | points | " + " | ".join(cols) + " | f2 u16 / peer | f2 u8 / peer |")
    print("|---|---:|" + "---:|" * (len(cols) + 2))
    for r in rows:
        cells = [f"{r[c] / r['points']:.3f}" for c in cols]
        print(f"| {r['volume']} | {r['points']:,} | " + " | ".join(cells) +
              f" | {r['ratio_u16']:.2f} | {r['ratio_u8']:.2f} |")
    print("\nBytes per grid point; peer = the smaller of zstd -19 and HDF5.\n")
    cols = ["field_pyramid", "coarse_errors_u16", "coarse_errors_u8", "next_u16", "next_u8"]
    print("| volume | " + " | ".join(cols) + " | next u16 / peer | next u8 / peer |")
    print("|---|" + "---:|" * (len(cols) + 2))
    for r in rows:
        cells = [f"{r[c] / r['points']:.3f}" for c in cols]
        print(f"| {r['volume']} | " + " | ".join(cells) +
              f" | {r['ratio_next_u16']:.2f} | {r['ratio_next_u8']:.2f} |")
    print("\nThe next layout's parts, bytes per grid point (next: their sum, header and index included).")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)
    if not args.work:
        shutil.rmtree(work)


if __name__ == "__main__":
    main()
