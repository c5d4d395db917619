#!/usr/bin/python3
"""Would prediction inside format 2's current blocks make them small enough?

For a format-2 store (`simplexdb import`), re-codes every stored
block and prints bytes per grid point, zstd level 3 per part:
  base        the blocks as stored (errors and field in one frame);
  err_raw     the error entries alone, bytes shuffled;
  fld_raw     the field alone, bytes shuffled;
  *_lor       after the 3D Lorenzo predictor over the block's box (a block
              inside one level's segment is a 16^3 box of that level's
              cubes in Morton order: a stride-2 sample of the grid);
  *_lorzig    the same, residuals zigzagged;
  err_delta   errors as differences along the Morton order.
Block 0 (mixed levels) is coded as it is in every column.

    /usr/bin/python3 bench/hz_block_prediction.py STORE.sdb
Needs python3-numpy and python3-zstandard (3D stores, 4096-record blocks).
"""
import struct
import sys

import numpy as np
import zstandard

VOXELS = {1: "u1", 2: "i1", 3: "<u2", 4: "<i2", 5: "<f4", 6: "<f8"}


def blocks(path):
    b = open(path, "rb").read()
    h = dict(dim=b[16], q=b[17], vt=b[18], k=b[19], bb=b[20],
             dims=struct.unpack_from("<4I", b, 24))
    virtual, _, bitmap, index = struct.unpack_from("<4Q", b, 152)
    words = np.frombuffer(b, dtype="<u8", count=(virtual + 63) // 64, offset=bitmap)
    present = np.nonzero(np.unpackbits(words.view(np.uint8), bitorder="little")[:virtual])[0]
    unpack = zstandard.ZstdDecompressor()
    for i, block in enumerate(present):
        offset, size, encoding = struct.unpack_from("<QIB", b, index + 40 * i)
        raw = b[offset:offset + size]
        if encoding == 2:
            raw = unpack.decompress(raw, max_output_size=1 << 24)
        yield h, int(block), raw


def box_coordinates(dim, bits):
    p = np.arange(1 << bits)
    c = np.zeros((dim, 1 << bits), dtype=np.int64)
    for bit in range(bits):
        c[bit % dim] |= ((p >> bit) & 1) << (bit // dim)
    return c


def lorenzo(a):
    for axis in range(a.ndim):
        a = np.diff(a, axis=axis, prepend=0)
    return a


def shuffle(a, width):
    u = a.astype(np.int64) & ((1 << (8 * width)) - 1)
    return b"".join(((u >> (8 * i)) & 255).astype(np.uint8).tobytes() for i in range(width))


def zigzag(r, width):
    half = 1 << (8 * width - 1)
    r = ((r + half) & ((1 << (8 * width)) - 1)) - half
    return np.where(r >= 0, 2 * r, -2 * r - 1)


def main():
    pack = zstandard.ZstdCompressor(level=3)
    size = lambda data: len(pack.compress(data))
    total = dict.fromkeys(["base", "err_raw", "fld_raw", "err_lor", "fld_lor", "err_lorzig",
                           "fld_lorzig", "err_delta"], 0)
    points = None
    for h, block, raw in blocks(sys.argv[1]):
        dim, bits = h["dim"], h["bb"]
        n = 1 << bits
        if points is None:
            points = int(np.prod(h["dims"]))
            coords = box_coordinates(dim, bits)
        ew = {1: 2, 2: 1, 3: 4}[h["q"]]
        ftype = np.dtype(VOXELS[h["vt"]])
        fw = ftype.itemsize
        e = np.frombuffer(raw, dtype={2: "<u2", 1: "u1", 4: "<u4"}[ew], count=n).astype(np.int64)
        f = np.frombuffer(raw, dtype=ftype, count=n, offset=n * ew)
        f = (f.view(f"<i{fw}") if ftype.kind == "f" else f).astype(np.int64)
        total["base"] += size(raw)
        total["err_raw"] += size(shuffle(e, ew))
        total["fld_raw"] += size(shuffle(f, fw))
        if block == 0 or bits % dim != 0:
            for key in ("err_lor", "err_lorzig", "err_delta"):
                total[key] += size(shuffle(e, ew))
            for key in ("fld_lor", "fld_lorzig"):
                total[key] += size(shuffle(f, fw))
            continue
        shape = (1 << (bits // dim),) * dim

        def grid(values):
            g = np.zeros(shape, dtype=np.int64)
            g[tuple(coords[dim - 1 - a] for a in range(dim))] = values
            return g
        re, rf = lorenzo(grid(e)), lorenzo(grid(f))
        total["err_lor"] += size(shuffle(re, ew))
        total["fld_lor"] += size(shuffle(rf, fw))
        total["err_lorzig"] += size(shuffle(zigzag(re, ew), ew))
        total["fld_lorzig"] += size(shuffle(zigzag(rf, fw), fw))
        total["err_delta"] += size(shuffle(np.diff(e, prepend=0), ew))
    print(sys.argv[1], {k: round(v / points, 3) for k, v in total.items()})


if __name__ == "__main__":
    main()
