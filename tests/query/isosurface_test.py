#!/usr/bin/python3
"""`simplexdb isosurface` (issue 43) against independent truth:

- brute force: marching tetrahedra written here, over the tetrahedra that
  `extract --iso V --error E -o m.vtu` writes (read by VTK), by the rule of
  query/isosurface.h, gives the same oriented triangles as the .vtp, for HT
  volumes (non-cubic, uint8 with values exactly at V, float32 with spacing
  and a flipped axis) at several E, and for HP time slices;
- watertight: every edge of the surface is used by two triangles in
  opposite directions, but edges on the grid's boundary faces (one) and
  grid edges whose ends both hold V exactly (where two sheets touch: twice
  each way or more);
- each point's value in the field at full resolution (VTK's probe of the
  `--error 0` mesh, linear on its tetrahedra) is within E of V;
- the normals point toward increasing values (a distance field, whose
  gradient points away from its centre);
- VTK reads the .vtp (points, triangles, normals, error) and its PLY
  reader the .ply (the same points and triangles).

    isosurface_test.py SIMPLEXDB_CLI WORKDIR

Exits 77 (skipped) without VTK or numpy.
"""
import json
import os
import shutil
import subprocess
import sys

try:
    import numpy as np
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy
except ImportError as error:
    print(f"cannot import numpy or vtk: {error}", file=sys.stderr)
    sys.exit(77)

CLI, WORK = sys.argv[1], sys.argv[2]
failures = []


def run(args):
    p = subprocess.run([CLI] + args, capture_output=True, text=True)
    if p.returncode != 0:
        raise SystemExit(f"simplexdb {' '.join(args)}: exit {p.returncode}\n{p.stderr}")
    return p.stdout


def read_vtu(path):
    r = vtk.vtkXMLUnstructuredGridReader()
    r.SetFileName(path)
    r.Update()
    g = r.GetOutput()
    points = vtk_to_numpy(g.GetPoints().GetData()).astype(float)
    cells = vtk_to_numpy(g.GetCells().GetConnectivityArray()).reshape(-1, 4)
    field = vtk_to_numpy(g.GetPointData().GetArray("field"))
    error = vtk_to_numpy(g.GetCellData().GetArray("error"))
    return points, cells, field, error


def read_vtp(path):
    r = vtk.vtkXMLPolyDataReader()
    r.SetFileName(path)
    r.Update()
    s = r.GetOutput()
    points = vtk_to_numpy(s.GetPoints().GetData()).astype(float) if s.GetNumberOfPoints() else np.zeros((0, 3))
    polys = vtk_to_numpy(s.GetPolys().GetConnectivityArray()).reshape(-1, 3) if s.GetNumberOfPolys() else \
        np.zeros((0, 3), int)
    offsets = vtk_to_numpy(s.GetPolys().GetOffsetsArray())
    if len(offsets) and np.any(np.diff(offsets) != 3):
        failures.append(f"{path}: polygons other than triangles")
    normals = s.GetPointData().GetArray("Normals")
    error = s.GetCellData().GetArray("error")
    return s, points, polys, (vtk_to_numpy(normals) if normals else None), (vtk_to_numpy(error) if error else None)


def to_grid(points, info):
    return (points - np.array(info["origin"][:3])) / np.array(info["spacing"][:3])


def zyx_before(p, q):
    return (p[2], p[1], p[0]) < (q[2], q[1], q[0])


def marching_tetrahedra(points, cells, field, errors, iso):
    """The rule of query/isosurface.h, written again: oriented triangles
    as tuples of point coordinates (grid units), with their errors."""
    names = {}      # what names a point -> its coordinates
    def edge_point(i, o):   # i inside, o outside (point indices)
        if field[i] == iso:
            return ("v", i), tuple(points[i])
        a, b = (i, o) if zyx_before(points[i], points[o]) else (o, i)
        key = ("e", a, b)
        if key not in names:
            t = (iso - field[a]) / (field[b] - field[a])
            names[key] = tuple(points[a] + t * (points[b] - points[a]))
        return key, names[key]

    triangles, sheets = [], {}
    def triangle(corners, low, err):
        keys = [k for k, _ in corners]
        if len(set(keys)) < 3:
            return
        p = [np.array(c) for _, c in corners]
        n = np.cross(p[1] - p[0], p[2] - p[0])
        if not n.any():
            return
        if np.dot(n, low - p[0]) > 0:
            corners = [corners[0], corners[2], corners[1]]
        if all(k[0] == "v" for k in keys):
            s = tuple(sorted(k[1] for k in keys))
            if s in sheets:
                triangles[sheets.pop(s)] = None
                return
            sheets[s] = len(triangles)
        triangles.append((tuple(c for _, c in corners), err))

    for c, tet in enumerate(cells):
        f = field[tet]
        inside = [int(v) for v, x in zip(tet, f) if x >= iso]
        outside = [int(v) for v, x in zip(tet, f) if x < iso]
        if not inside or not outside:
            continue
        low = points[outside[0]]
        if len(inside) != 2:
            lone = inside[0] if len(inside) == 1 else outside[0]
            others = [int(v) for v in tet if v != lone]
            corners = [edge_point(lone, o) if len(inside) == 1 else edge_point(o, lone) for o in others]
            triangle(corners, low, errors[c])
            continue
        pairs = [(inside[0], outside[0]), (inside[0], outside[1]), (inside[1], outside[1]), (inside[1], outside[0])]
        q = [edge_point(i, o) for i, o in pairs]
        def order(pair):
            a, b = (points[pair[0]], points[pair[1]]) if zyx_before(points[pair[0]], points[pair[1]]) else \
                (points[pair[1]], points[pair[0]])
            return (a[2], a[1], a[0], b[2], b[1], b[0])
        d = min(range(4), key=lambda k: order(pairs[k])) % 2
        triangle([q[d], q[d + 1], q[d + 2]], low, errors[c])
        triangle([q[d], q[d + 2], q[(d + 3) % 4]], low, errors[c])
    return [t for t in triangles if t is not None]


def canonical(tri, digits=6):
    """An oriented triangle, its points rounded, rotated to start at the
    smallest point (rotation keeps the orientation)."""
    pts = [tuple(round(x, digits) + 0.0 for x in p) for p in tri]
    k = min(range(3), key=lambda i: pts[i])
    return tuple(pts[k:] + pts[:k])


def check_case(label, store, iso, error, extra=(), info=None, fine=None, box=None):
    vtu = os.path.join(WORK, label + ".vtu")
    vtp = os.path.join(WORK, label + ".vtp")
    ply = os.path.join(WORK, label + ".ply")
    run(["extract", store, "--iso", str(iso), "--error", error, "-o", vtu, "--force"] + list(extra))
    report = json.loads(run(["isosurface", store, "--iso", str(iso), "--error", error, "-o", vtp, "--force",
                             "--json"] + list(extra)))
    run(["isosurface", store, "--iso", str(iso), "--error", error, "-o", ply, "--force", "-q"] + list(extra))
    points, cells, field, errors = read_vtu(vtu)
    grid_points = to_grid(points, info)
    want = marching_tetrahedra(grid_points, cells, field, errors, iso)
    surface, got_points, got_tris, normals, got_errors = read_vtp(vtp)
    got_grid = to_grid(got_points, info)
    # Orientation is compared in grid units: an odd number of flipped axes
    # mirrors the physical surface, whose triangles are reversed for it.
    flips = sum(s < 0 for s in info["spacing"][:3]) % 2
    got = [tuple(got_grid[i] for i in (t if not flips else t[[0, 2, 1]])) for t in got_tris]
    if report["triangles"] != len(got_tris):
        failures.append(f"{label}: the report says {report['triangles']} triangles, the .vtp holds {len(got_tris)}")
    a = sorted(canonical(t) for t, _ in want)
    b = sorted(canonical(t) for t in got)
    if a != b:
        sa, sb = set(a), set(b)
        failures.append(f"{label}: {len(b)} triangles against brute force's {len(a)}: {len(sb - sa)} not in it, "
                        f"{len(sa - sb)} missing (e.g. {sorted(sb - sa)[:1]} / {sorted(sa - sb)[:1]})")
    # Each triangle's error: its tetrahedron's.
    want_err = sorted((canonical(t), e) for t, e in want)
    got_err = sorted((canonical(t), e) for t, e in zip(got, got_errors))
    if [e for _, e in want_err] != [e for _, e in got_err] and a == b:
        failures.append(f"{label}: the triangles' errors are not their tetrahedra's")
    if len(got_tris) == 0:
        failures.append(f"{label}: an empty surface (choose an isovalue inside the field)")
    watertight(label, got_grid, got_tris, info["dims"][:3])
    if normals is None or normals.shape != got_points.shape:
        failures.append(f"{label}: no Normals array of one vector per point")
    elif not np.allclose(np.linalg.norm(normals, axis=1)[np.linalg.norm(normals, axis=1) > 0], 1, atol=1e-5):
        failures.append(f"{label}: normals not of unit length")
    if fine is not None:
        within_bound(label, fine, got_points, iso, report["threshold"], box)
    read_ply(label, ply, got_points, got_tris)
    print(f"{label}: {len(got_tris)} triangles, {len(got_points)} points from {len(cells)} tetrahedra, "
          f"{report['triangles_per_second'] / 1e6:.2f} M triangles/s")
    return got_points, normals


def watertight(label, grid, tris, dims):
    """Closed and consistently oriented: each edge used as often in one
    direction as in the other; an edge with no reverse only on a boundary
    face of the grid; more than one triangle each way only along a grid
    edge whose two ends hold the isovalue exactly (two sheets of the
    surface touching there)."""
    directed = {}
    for t in tris:
        for k in range(3):
            e = (int(t[k]), int(t[(k + 1) % 3]))
            directed[e] = directed.get(e, 0) + 1
    last = np.array(dims, float) - 1
    def on_grid_point(p):
        return np.all(grid[p] == np.round(grid[p]))
    unbalanced = crowded = open_edges = 0
    for (a, b), n in directed.items():
        back = directed.get((b, a), 0)
        if back == 0:
            if not any(grid[a][k] == grid[b][k] and grid[a][k] in (0.0, last[k]) for k in range(3)):
                open_edges += 1
        elif back != n:
            unbalanced += 1
        elif n > 1 and not (on_grid_point(a) and on_grid_point(b)):
            crowded += 1
    if open_edges:
        failures.append(f"{label}: {open_edges} edges open inside the grid (cracks)")
    if unbalanced:
        failures.append(f"{label}: {unbalanced} edges used more often in one direction than the other")
    if crowded:
        failures.append(f"{label}: {crowded} edges of more than two triangles between points that are not grid points")


def within_bound(label, fine_vtu, points, iso, threshold, box=None):
    r = vtk.vtkXMLUnstructuredGridReader()
    r.SetFileName(fine_vtu)
    r.Update()
    pts = vtk.vtkPoints()
    for p in points:
        pts.InsertNextPoint(*p)
    probe_input = vtk.vtkPolyData()
    probe_input.SetPoints(pts)
    probe = vtk.vtkProbeFilter()
    probe.SetInputData(probe_input)
    probe.SetSourceData(r.GetOutput())
    probe.SetTolerance(1e-6)
    probe.Update()
    out = probe.GetOutput()
    values = vtk_to_numpy(out.GetPointData().GetArray("field"))
    valid = vtk_to_numpy(out.GetPointData().GetArray(probe.GetValidPointMaskArrayName())).astype(bool)
    if valid.mean() < 0.99:
        failures.append(f"{label}: VTK's probe found only {valid.mean():.1%} of the points in the fine mesh")
    if box is not None:  # only the box is held to the bound
        valid &= np.all((points >= box[:3]) & (points <= box[3:]), axis=1)
    worst = np.max(np.abs(values[valid] - iso)) if valid.any() else 0
    lo, hi = r.GetOutput().GetPointData().GetArray("field").GetRange()
    if worst > threshold + 1e-6 * (hi - lo):  # the probe's rounding
        failures.append(f"{label}: a point's full-resolution value is {worst} from the isovalue, bound {threshold}")


def read_ply(label, path, points, tris):
    r = vtk.vtkPLYReader()
    r.SetFileName(path)
    r.Update()
    s = r.GetOutput()
    if s.GetNumberOfPoints() != len(points) or s.GetNumberOfPolys() != len(tris):
        failures.append(f"{label}: the PLY reader read {s.GetNumberOfPoints()} points and {s.GetNumberOfPolys()} "
                        f"faces, not {len(points)} and {len(tris)}")
        return
    p = vtk_to_numpy(s.GetPoints().GetData())
    f = vtk_to_numpy(s.GetPolys().GetConnectivityArray()).reshape(-1, 3)
    if not np.allclose(p, points, rtol=1e-6, atol=1e-4) or not np.array_equal(f, tris):
        failures.append(f"{label}: the .ply's points or faces differ from the .vtp's")


def main():
    shutil.rmtree(WORK, ignore_errors=True)
    os.makedirs(WORK)

    # HT, uint8 Perlin, not a cube (clipped), integer isovalues: many
    # vertices exactly at V.
    vol = os.path.join(WORK, "p.nrrd")
    store = os.path.join(WORK, "p.sdb")
    run(["generate", "--field", "perlin", "--dims", "33,29,40", "--type", "uint8", "--seed", "3", "-o", vol, "-q"])
    run(["import", vol, "-o", store, "-q"])
    info = json.loads(run(["info", store, "--json"]))
    fine = os.path.join(WORK, "p_fine.vtu")
    run(["extract", store, "--error", "0", "-o", fine])
    for iso, error in ((128, "0"), (128, "2%"), (100, "6%"), (171, "1%")):
        check_case(f"perlin_{iso}_{error.rstrip('%')}", store, iso, error, info=info, fine=fine)
    check_case("perlin_box", store, 128, "8%", ["--box", "0,0,0,12,12,12"], info=info, fine=fine,
               box=np.array([0, 0, 0, 12, 12, 12.0]))

    # HT, float32 distance from a centre, spacing with a flipped axis: the
    # normals (the gradient) point away from the centre.
    z, y, x = np.mgrid[0:21, 0:25, 0:30]
    centre = np.array([14.2, 11.7, 9.9])
    dist = np.sqrt((x - centre[0]) ** 2 + (y - centre[1]) ** 2 + (z - centre[2]) ** 2).astype("<f4")
    raw = os.path.join(WORK, "d.raw")
    dist.tofile(raw)
    dstore = os.path.join(WORK, "d.sdb")
    run(["import", raw, "--dims", "30,25,21", "--type", "float32", "--spacing=-0.5,0.25,2", "--origin", "10,0,-4",
         "-o", dstore, "-q"])
    dinfo = json.loads(run(["info", dstore, "--json"]))
    dfine = os.path.join(WORK, "d_fine.vtu")
    run(["extract", dstore, "--error", "0", "-o", dfine])
    for error in ("0.5%", "3%"):
        pts, normals = check_case(f"distance_{error.rstrip('%')}", dstore, 7.5, error, info=dinfo, fine=dfine)
        c = np.array(dinfo["origin"][:3]) + centre * np.array(dinfo["spacing"][:3])
        # The gradient of the distance in physical space is along
        # (p - c) scaled by 1/spacing^2 per axis; its sign is what counts.
        outward = np.einsum("ij,ij->i", normals, (pts - c) / np.array(dinfo["spacing"][:3]) ** 2)
        if np.mean(outward > 0) < 0.999:
            failures.append(f"distance {error}: {np.mean(outward <= 0):.2%} of the normals point inward")

    # HP: a Perlin series, slices at a grid time and between two.
    hp = os.path.join(WORK, "hp.nrrd")
    hstore = os.path.join(WORK, "hp.sdb")
    run(["generate", "--field", "perlin", "--dims", "9,9,9,9", "--type", "uint8", "--seed", "2", "-o", hp, "-q"])
    run(["import", hp, "-o", hstore, "-q"])
    hinfo = json.loads(run(["info", hstore, "--json"]))
    for t in ("3", "4.5"):
        check_case(f"hp_t{t}", hstore, 120, "2%", ["--time", t], info=hinfo)

    # Refusals: no .vtp/.ply extension, an HP without --time.
    p = subprocess.run([CLI, "isosurface", store, "--iso", "128", "-o", os.path.join(WORK, "s.vtk")],
                       capture_output=True, text=True)
    if p.returncode != 2 or ".vtp" not in p.stderr:
        failures.append(f"isosurface -o s.vtk: exit {p.returncode}, {p.stderr!r}")
    p = subprocess.run([CLI, "isosurface", hstore, "--iso", "120", "-o", os.path.join(WORK, "s.vtp")],
                       capture_output=True, text=True)
    if p.returncode != 2 or "--time" not in p.stderr or os.path.exists(os.path.join(WORK, "s.vtp")):
        failures.append(f"isosurface of an HP without --time: exit {p.returncode}, {p.stderr!r}")

    for f in failures:
        print("FAILED:", f, file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
