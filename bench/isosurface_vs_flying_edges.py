#!/usr/bin/python3
"""Isosurfaces straight from the hierarchy against VTK's flying edges
(issue 43), as whole processes, one run each:

- flying edges: `/usr/bin/python3` with VTK reads the raw volume (numpy),
  runs vtkFlyingEdges3D at the isovalue (normals on, as ours) and writes
  the surface with vtkXMLPolyDataWriter (zlib, appended binary);
- ours: `simplexdb isosurface STORE --iso V --error E -o S.vtp --json` over
  the store `simplexdb import` built from the same file (the build is not
  timed: the store is what a user keeps), for each E given.

For each: wall time, triangles, and (ours) the ratio of time and triangles
to flying edges', and the distance between the two surfaces in voxels,
sampled both ways (each surface's points to the other surface, by VTK's
vtkImplicitPolyDataDistance): the mean and the largest.

    bench/isosurface_vs_flying_edges.py VOLUME:ISO[:IMPORT_OPTION...] ... [--errors 1%,5%] [--work DIR]

VOLUME is a raw file (give --dims and --type among the import options) or
an NRRD file of `simplexdb generate` (raw encoding). Needs build/release.
"""
import argparse
import json
import os
import subprocess
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CLI = os.path.join(ROOT, "build", "release", "tools", "simplexdb")
PYTHON = "/usr/bin/python3"

FLYING_EDGES = r'''
import sys, numpy as np, vtk
from vtk.util.numpy_support import numpy_to_vtk
path, dims, dtype, offset, iso, out = sys.argv[1], [int(x) for x in sys.argv[2].split(",")], sys.argv[3], \
    int(sys.argv[4]), float(sys.argv[5]), sys.argv[6]
a = np.fromfile(path, dtype=dtype, offset=offset, count=dims[0] * dims[1] * dims[2])
image = vtk.vtkImageData()
image.SetDimensions(*dims)
scalars = numpy_to_vtk(a, deep=False)
scalars.SetName("field")
image.GetPointData().SetScalars(scalars)
fe = vtk.vtkFlyingEdges3D()
fe.SetInputData(image)
fe.SetValue(0, iso)
fe.ComputeNormalsOn()
fe.ComputeGradientsOff()
fe.ComputeScalarsOff()
w = vtk.vtkXMLPolyDataWriter()
w.SetInputConnection(fe.GetOutputPort())
w.SetFileName(out)
w.SetDataModeToAppended()
w.SetCompressorTypeToZLib()
w.Write()
print(fe.GetOutput().GetNumberOfPolys())
'''

DISTANCE = r'''
import sys, numpy as np, vtk
from vtk.util.numpy_support import vtk_to_numpy
def read(p):
    r = vtk.vtkXMLPolyDataReader(); r.SetFileName(p); r.Update(); return r.GetOutput()
def sampled(s, n=20000):
    pts = vtk_to_numpy(s.GetPoints().GetData())
    step = max(1, len(pts) // n)
    return pts[::step]
def one_way(a, b):
    d = vtk.vtkImplicitPolyDataDistance(); d.SetInput(b)
    return np.array([abs(d.EvaluateFunction(*p)) for p in sampled(a)])
a, b = read(sys.argv[1]), read(sys.argv[2])
both = np.concatenate([one_way(a, b), one_way(b, a)])
print(f"{both.mean()} {both.max()}")
'''


def timed(command):
    start = time.monotonic()
    p = subprocess.run(command, check=True, capture_output=True, text=True)
    return time.monotonic() - start, p.stdout


def raw_layout(volume, options):
    """dims, numpy dtype and data offset of the volume, as import reads it."""
    if volume.endswith(".nrrd"):
        header = {}
        with open(volume, "rb") as f:
            while True:
                line = f.readline().decode().strip()
                if not line:
                    break
                if ":" in line and not line.startswith("#"):
                    k, v = line.split(":", 1)
                    header[k.strip()] = v.strip()
            offset = f.tell()
        assert header.get("encoding") == "raw", "raw NRRD only"
        types = {"uint8": "u1", "int16": "i2", "uint16": "u2", "float": "f4", "float32": "f4"}
        endian = "<" if header.get("endian", "little") == "little" else ">"
        return header["sizes"].replace(" ", ","), endian + types[header["type"]], offset
    o = dict(zip(options[::2], options[1::2]))
    types = {"uint8": "u1", "int16": "i2", "uint16": "u2", "float32": "f4", "float64": "f8"}
    return o["--dims"], ("<" if o.get("--endian", "little") == "little" else ">") + types[o["--type"]], \
        int(o.get("--offset", 0))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("volumes", nargs="+")
    parser.add_argument("--errors", default="1%,5%")
    parser.add_argument("--work", default="/tmp/simplexdb_iso_bench")
    a = parser.parse_args()
    os.makedirs(a.work, exist_ok=True)
    rows = []
    for spec in a.volumes:
        volume, iso, *options = spec.split(":")
        name = os.path.basename(volume).split(".")[0]
        store = os.path.join(a.work, name + ".sdb")
        subprocess.run([CLI, "import", volume, "-o", store, "-q", "--force"] + options, check=True)
        dims, dtype, offset = raw_layout(volume, options)
        fe_out = os.path.join(a.work, name + "_fe.vtp")
        fe_time, out = timed([PYTHON, "-c", FLYING_EDGES, volume, dims, dtype, str(offset), iso, fe_out])
        fe_tris = int(out.split()[-1])
        print(f"{name} at {iso}: flying edges {fe_time:.2f} s, {fe_tris:,} triangles", flush=True)
        for error in a.errors.split(","):
            ours = os.path.join(a.work, f"{name}_{error.rstrip('%')}.vtp")
            t, out = timed([CLI, "isosurface", store, "--iso", iso, "--error", error, "-o", ours, "--force",
                            "--json"])
            j = json.loads(out)
            _, d = timed([PYTHON, "-c", DISTANCE, ours, fe_out])
            mean, worst = (float(x) for x in d.split())
            row = (name, iso, error, fe_time, fe_tris, t, j["triangles"], fe_time / t, j["triangles"] / fe_tris,
                   mean, worst, j["triangles_per_second"] / 1e6, j["blocks_decoded"], j["distinct_blocks"],
                   j["peak_memory_bytes"] / 2**20)
            rows.append(row)
            print(f"  --error {error}: {t:.2f} s ({fe_time / t:.2f}x faster), {j['triangles']:,} triangles "
                  f"({j['triangles'] / fe_tris:.2f} of flying edges'), distance mean {mean:.3f} max {worst:.3f} "
                  f"voxels, contour {j['triangles_per_second'] / 1e6:.2f} M triangles/s", flush=True)
    print("\n| volume, iso | error | flying edges (s) | triangles | ours (s) | triangles | speed-up | "
          "triangles / FE's | distance mean / max (voxels) | contour (M tri/s) | decoded / distinct | peak (MiB) |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---|---:|---|---:|")
    for r in rows:
        print(f"| {r[0]}, {r[1]} | {r[2]} | {r[3]:.2f} | {r[4]:,} | {r[5]:.2f} | {r[6]:,} | {r[7]:.2f}x | "
              f"{r[8]:.2f} | {r[9]:.3f} / {r[10]:.2f} | {r[11]:.2f} | {r[12]:,} / {r[13]:,} | {r[14]:.0f} |")


if __name__ == "__main__":
    main()
