#!/usr/bin/env python3
"""SimplexDB from Python on a real volume: the tooth CT of ../shared/data
(the volume the demo uses), imported from a numpy array into a store,
extracted at two error thresholds, and drawn with matplotlib:

  mesh_sizes.png   the meshes' tetrahedra and points per threshold
  slice.png        the store's field on a plane z = const (store.field_at),
                   with the cells of each mesh that cross that plane drawn
                   over it (where the mesh is fine the field changes fast)

    PYTHONPATH=build/release/python python3 examples/python_thresholds.py [OUT]

OUT defaults to out/python-example (ignored by git). Needs numpy and
matplotlib (Debian: python3-numpy, python3-matplotlib).
"""
import argparse
import pathlib
import sys

import numpy as np

import simplexdb

REPOSITORY = pathlib.Path(__file__).resolve().parent.parent
# The tooth: 103 x 94 x 161 uint8, x fastest (../shared/data/README.md).
TOOTH = pathlib.Path("tooth/tooth_103x94x161_uint8.raw")
DIMS = (103, 94, 161)
THRESHOLDS = ("5%", "15%")  # of the field range: fine and coarse


def import_tooth(raw, out):
    """The store of the tooth at `out`, built from the raw file read as a
    numpy array (C order: z, y, x), which import_volume reads in place."""
    if out.exists():
        out.unlink()  # a store from an earlier run
    voxels = np.fromfile(raw, dtype=np.uint8).reshape(DIMS[::-1])
    return simplexdb.import_volume(voxels, out, progress=False)


def cut(mesh, store, z):
    """The polygons (triangles and quadrilaterals, in grid units x, y) where the
    plane z (grid units) cuts the mesh's tetrahedra. REQUIRES: no mesh point
    lies on the plane (z half-way between grid planes: mesh points lie on grid
    points). Cost: O(cells) numpy work, then a Python loop over the cells cut."""
    points = (mesh.points - np.array(store.origin)) / np.array(store.spacing)  # back to grid units
    corners = points[mesh.cells]  # cells x 4 x 3
    above = corners[:, :, 2] > z
    crossing = above.any(axis=1) & ~above.all(axis=1)
    corners = corners[crossing]
    edges = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
    a = corners[:, [e[0] for e in edges]]
    b = corners[:, [e[1] for e in edges]]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (z - a[:, :, 2]) / (b[:, :, 2] - a[:, :, 2])  # edges in the plane's direction: nan, no hit
        xy = a[:, :, :2] + s[:, :, None] * (b[:, :, :2] - a[:, :, :2])
    hits = (s > 0) & (s < 1)
    polygons = []
    for cell_xy, cell_hits in zip(xy, hits):
        p = cell_xy[cell_hits]  # 3 or 4 points of a convex polygon
        centre = p.mean(axis=0)
        polygons.append(p[np.argsort(np.arctan2(p[:, 1] - centre[1], p[:, 0] - centre[0]))])
    return polygons


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", nargs="?", default=str(REPOSITORY / "out/python-example"),
                        help="the folder for the PNGs and the store (default: out/python-example)")
    parser.add_argument("--data", default=str(REPOSITORY.parent / "shared/data"),
                        help="the shared data folder (default: ../shared/data beside the repository)")
    args = parser.parse_args()
    raw = pathlib.Path(args.data) / TOOTH
    if not raw.is_file():
        sys.exit(f"python_thresholds.py: {raw}: no such file (the tooth of ../shared/data, 103x94x161 uint8)")
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    import matplotlib
    matplotlib.use("Agg")  # files only, no display
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection

    store = import_tooth(raw, out / "tooth.sdb")
    meshes = {t: store.extract(t) for t in THRESHOLDS}
    for t, mesh in meshes.items():
        print(f"{t}: {len(mesh.cells):,} tetrahedra, {len(mesh.points):,} points "
              f"(threshold {mesh.stats['threshold']:.4g} of the range {store.field_range})")

    # The meshes' sizes per threshold.
    fig, ax = plt.subplots(figsize=(6, 4))
    x = np.arange(len(THRESHOLDS))
    for offset, (label, count) in zip((-0.2, 0.2), (("tetrahedra", lambda m: len(m.cells)),
                                                    ("points", lambda m: len(m.points)))):
        bars = ax.bar(x + offset, [count(m) for m in meshes.values()], 0.4, label=label)
        ax.bar_label(bars, fmt="{:,.0f}")
    ax.set_xticks(x, [f"error <= {t}" for t in THRESHOLDS])
    ax.set_ylabel("count")
    ax.set_title(f"tooth {DIMS[0]}x{DIMS[1]}x{DIMS[2]}: extracted mesh per error threshold")
    ax.legend()
    fig.tight_layout()
    sizes_png = out / "mesh_sizes.png"
    fig.savefig(sizes_png, dpi=100)
    plt.close(fig)

    # The plane half-way between two grid planes (no mesh point lies on it),
    # and the store's full-resolution field there, as the hierarchy
    # interpolates it.
    z = DIMS[2] // 2 + 0.5
    y, x = np.mgrid[0:DIMS[1], 0:DIMS[0]]
    plane = np.stack([x.ravel(), y.ravel(), np.full(x.size, z)], axis=1).astype(np.float64)
    image = store.field_at(plane, units="grid").reshape(DIMS[1], DIMS[0])
    fig, axes = plt.subplots(1, len(THRESHOLDS), figsize=(6 * len(THRESHOLDS), 5.5))
    for ax, (t, mesh) in zip(np.atleast_1d(axes), meshes.items()):
        ax.imshow(image, origin="lower", cmap="gray", extent=(-0.5, DIMS[0] - 0.5, -0.5, DIMS[1] - 0.5))
        polygons = cut(mesh, store, z)
        ax.add_collection(PolyCollection(polygons, facecolors="none", edgecolors="tab:orange", linewidths=0.4))
        ax.set_title(f"error <= {t}: {len(polygons):,} tetrahedra cross z = {z}")
        ax.set_xlabel("x")
        ax.set_ylabel("y")
    fig.tight_layout()
    slice_png = out / "slice.png"
    fig.savefig(slice_png, dpi=100)
    plt.close(fig)

    for path in (sizes_png, slice_png):
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
