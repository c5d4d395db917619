#!/usr/bin/python3
"""`mpirun -np N simplexdb extract STORE ... -o OUT.pvtu` (issue 42) against
the one-process extraction, read back with VTK's own readers
(vtkXMLPUnstructuredGridReader for the pieces, vtkXMLUnstructuredGridReader
for the one-process .vtu): the union of the pieces is the one-process mesh
cell for cell (each cell's code and its four points), for uniform, box and
isovalue queries of an HT and time slices of an HP (one, and a .pvd series
of .pvtu files), N = 1..4; the statistics
add up; `isosurface -o OUT.pvtp` gives the one-process surface's triangles
in pieces (vtkXMLPPolyDataReader); a rank that fails leaves neither the .pvtu nor any piece, and every
rank stops with one message naming the failing rank.

    mpi_extract_test.py SIMPLEXDB_CLI WORKDIR

Exits 77 (skipped) when VTK or mpirun is missing.
"""
import json
import os
import shutil
import sys

from mpi_cli import require_mpirun, runner

try:
    from vtkmodules.vtkIOXML import (vtkXMLPPolyDataReader, vtkXMLPolyDataReader, vtkXMLPUnstructuredGridReader,
                                     vtkXMLUnstructuredGridReader)
    from vtkmodules.util.numpy_support import vtk_to_numpy
except ImportError as error:
    print(f"cannot import VTK: {error}", file=sys.stderr)
    sys.exit(77)

CLI, WORK = sys.argv[1], sys.argv[2]
require_mpirun()
run = runner(CLI)
failures = []


def cells(grid):
    """The cells as a sorted list of (code, the four points sorted)."""
    points = vtk_to_numpy(grid.GetPoints().GetData())
    codes = vtk_to_numpy(grid.GetCellData().GetArray("code"))
    conn = vtk_to_numpy(grid.GetCells().GetConnectivityArray()).reshape(-1, 4)
    return sorted((int(codes[i]), tuple(sorted(tuple(points[j]) for j in conn[i]))) for i in range(len(codes)))


def read(path, parallel):
    reader = vtkXMLPUnstructuredGridReader() if parallel else vtkXMLUnstructuredGridReader()
    reader.SetFileName(path)
    reader.Update()
    return reader.GetOutput()


def check(name, store, query, pieces):
    one = os.path.join(WORK, name + "_one.vtu")
    run(["extract", store, "-o", one, "--force"] + query)
    want = cells(read(one, False))
    assert want, name
    for n in pieces:
        out = os.path.join(WORK, f"{name}_{n}.pvtu")
        stats = json.loads(run(["extract", store, "-o", out, "--force"] + query, mpi=n).stdout)
        grid = read(out, True)
        got = cells(grid)
        label = f"{name}, {n} ranks"
        if got != want:
            failures.append(f"{label}: {len(got)} cells, the one-process mesh has {len(want)}"
                            f" ({len(set(got) - set(want))} not in it, {len(set(want) - set(got))} missing)")
        if stats["pieces"] != n or len(stats["per_piece"]) != n:
            failures.append(f"{label}: statistics of {stats['pieces']} pieces")
        if sum(p["cells_written"] for p in stats["per_piece"]) != grid.GetNumberOfCells():
            failures.append(f"{label}: the pieces' cells_written do not add up to what VTK read")
        if n > 1 and stats["exchange_rounds"] < 2:
            failures.append(f"{label}: {stats['exchange_rounds']} rounds of exchange")
        print(f"{label}: {grid.GetNumberOfCells()} cells, {stats['exchange_rounds']} rounds, "
              f"{stats['exchange_bytes_sent']} bytes exchanged, largest piece {stats['largest_piece_over_mean']:.3f}"
              " of the mean")


def triangles(path, parallel):
    """A surface's triangles as a sorted list of their three points, each
    rotated to start at its smallest point (orientation kept)."""
    reader = vtkXMLPPolyDataReader() if parallel else vtkXMLPolyDataReader()
    reader.SetFileName(path)
    reader.Update()
    s = reader.GetOutput()
    points = vtk_to_numpy(s.GetPoints().GetData())
    out = []
    for t in vtk_to_numpy(s.GetPolys().GetConnectivityArray()).reshape(-1, 3):
        p = [tuple(points[i]) for i in t]
        k = p.index(min(p))
        out.append(tuple(p[k:] + p[:k]))
    return sorted(out)


def check_surface(name, store, query, pieces):
    """`isosurface -o OUT.pvtp` in N pieces: the one-process .vtp's
    triangles, each once."""
    one = os.path.join(WORK, name + "_one.vtp")
    run(["isosurface", store, "-o", one, "--force", "-q"] + query)
    want = triangles(one, False)
    assert want, name
    for n in pieces:
        out = os.path.join(WORK, f"{name}_{n}.pvtp")
        stats = json.loads(run(["isosurface", store, "-o", out, "--force", "--json"] + query, mpi=n).stdout)
        got = triangles(out, True)
        label = f"{name}, {n} ranks"
        if got != want:
            failures.append(f"{label}: {len(got)} triangles, the one-process surface has {len(want)}"
                            f" ({len(set(got) - set(want))} not in it, {len(set(want) - set(got))} missing)")
        if stats["triangles"] != len(got) or stats["pieces"] != n:
            failures.append(f"{label}: the statistics say {stats['triangles']} triangles in {stats['pieces']} pieces")
        print(f"{label}: {len(got)} triangles, the one-process surface")


def datasets(pvd):
    """A .pvd's (timestep, file) pairs."""
    import xml.etree.ElementTree as ET
    return [(float(d.get("timestep")), d.get("file")) for d in ET.parse(pvd).getroot().iter("DataSet")]


def check_series(name, store, query, pieces):
    """An HP's time slices (-o OUT.pvd): per slice a .pvtu of the pieces,
    each the one-process slice cell for cell, at the same times."""
    one = os.path.join(WORK, name + "_one.pvd")
    run(["extract", store, "-o", one, "--force"] + query)
    want = datasets(one)
    for n in pieces:
        out = os.path.join(WORK, f"{name}_{n}.pvd")
        run(["extract", store, "-o", out, "--force"] + query, mpi=n)
        got = datasets(out)
        label = f"{name}, {n} ranks"
        if [t for t, _ in got] != [t for t, _ in want] or not all(f.endswith(".pvtu") for _, f in got):
            failures.append(f"{label}: the .pvd names {got}, the one-process one {want}")
            continue
        for (t, f), (_, g) in zip(got, want):
            a = cells(read(os.path.join(WORK, f), True))
            b = cells(read(os.path.join(WORK, g), False))
            if a != b:
                failures.append(f"{label}, t = {t}: {len(a)} cells against {len(b)}")
        print(f"{label}: {len(got)} slices, each the one-process slice")


def main():
    shutil.rmtree(WORK, ignore_errors=True)
    os.makedirs(WORK)
    ht, hp = os.path.join(WORK, "ht.sdb"), os.path.join(WORK, "hp.sdb")
    for store, dims in ((ht, "49,41,33"), (hp, "17,17,17,9")):
        volume = store[:-4] + ".nrrd"
        run(["generate", "--field", "perlin", "--dims", dims, "--type", "uint8", "--seed", "3", "-o", volume,
             "--quiet"])
        run(["import", volume, "-o", store, "--quiet"])
    check("uniform", ht, ["--error", "2%"], [1, 2, 3, 4])
    check("box", ht, ["--error", "1%", "--box", "5,10,0,30,40,20"], [2, 3])
    check("iso", ht, ["--error", "1%", "--iso", "128"], [2, 4])
    check("time", hp, ["--error", "3%", "--time", "4"], [1, 2, 3])
    check("time_box", hp, ["--error", "2%", "--time", "2.5", "--box", "0,0,0,8,16,16"], [2, 4])
    check_series("series", hp, ["--error", "3%", "--slices", "1,4.5,8"], [2, 3])
    check_surface("surface", ht, ["--iso", "128", "--error", "1%"], [2, 3])
    check_surface("surface_hp", hp, ["--iso", "120", "--error", "2%", "--time", "4.5"], [2])

    # A rank that fails: rank 1's piece file cannot be written (a folder
    # stands there). Every rank stops, with rank 1's message once; no .pvtu
    # and no piece stays.
    out = os.path.join(WORK, "fails.pvtu")
    os.makedirs(os.path.join(WORK, "fails_1.vtu"))
    p = run(["extract", ht, "--error", "2%", "-o", out], mpi=2, expect=(1, 2))
    messages = [line for line in p.stderr.splitlines() if line.startswith("simplexdb:")]
    if len(messages) != 1 or "rank 1 of 2" not in messages[0] or "fails_1.vtu" not in messages[0]:
        failures.append(f"a failing rank: expected one message naming rank 1 and its file, got {messages}")
    left = sorted(f for f in os.listdir(WORK) if f.startswith("fails") and f != "fails_1.vtu")
    if left:
        failures.append(f"a failing rank left {left}")

    # Only import and extract run on several ranks; extract's formats other
    # than .pvtu and the statistics are refused, once.
    p = run(["info", ht], mpi=2, expect=(2,))
    if "only import, extract and isosurface" not in p.stderr or p.stderr.count("simplexdb:") != 1:
        failures.append(f"info under mpirun: {p.stderr!r}")
    p = run(["extract", ht, "--error", "2%", "-o", os.path.join(WORK, "x.vtu")], mpi=2, expect=(2,))
    if ".pvtu" not in p.stderr or p.stderr.count("simplexdb:") != 1:
        failures.append(f"extract -o x.vtu under mpirun: {p.stderr!r}")

    for f in failures:
        print("FAILED:", f, file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
