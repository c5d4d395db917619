#!/usr/bin/python3
"""Cuts a tetrahedral mesh (.vtu, as `simplexdb extract --format vtu` writes
it) by the plane z = Z with VTK and draws the cut as SVG: one polygon per
tetrahedron cut, filled by the field interpolated at its corners, outlined so
that cell sizes show where a query refined.

    bench/slice_svg.py MESH.vtu OUT.svg --z Z [--title TEXT] [--width PX]

Needs Debian's python3-vtk9. Used by bench/experiments.py for RESULTS.md.
"""
import argparse
import html

from vtkmodules.vtkCommonDataModel import vtkPlane
from vtkmodules.vtkFiltersCore import vtkCutter
from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridReader

# A perceptually ordered ramp (viridis' ends and three stops between).
STOPS = [(0.0, (68, 1, 84)), (0.25, (59, 82, 139)), (0.5, (33, 145, 140)),
         (0.75, (94, 201, 98)), (1.0, (253, 231, 37))]


def colour(t):
    t = min(max(t, 0.0), 1.0)
    for (t0, c0), (t1, c1) in zip(STOPS, STOPS[1:]):
        if t <= t1:
            u = (t - t0) / (t1 - t0)
            return "#%02x%02x%02x" % tuple(round(a + u * (b - a)) for a, b in zip(c0, c1))
    return "#%02x%02x%02x" % STOPS[-1][1]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("mesh")
    ap.add_argument("svg")
    ap.add_argument("--z", type=float, required=True, help="the cutting plane, grid units")
    ap.add_argument("--title", default="")
    ap.add_argument("--width", type=int, default=560)
    a = ap.parse_args()

    reader = vtkXMLUnstructuredGridReader()
    reader.SetFileName(a.mesh)
    reader.Update()
    grid = reader.GetOutput()
    if grid.GetNumberOfCells() == 0:
        raise SystemExit(f"{a.mesh}: no cells")
    plane = vtkPlane()
    plane.SetOrigin(0, 0, a.z)
    plane.SetNormal(0, 0, 1)
    cutter = vtkCutter()
    cutter.SetCutFunction(plane)
    cutter.SetInputData(grid)
    cutter.Update()
    cut = cutter.GetOutput()
    field = cut.GetPointData().GetArray("field")
    lo, hi = grid.GetPointData().GetArray("field").GetRange()
    x0, x1, y0, y1, _, _ = grid.GetBounds()
    scale = a.width / max(x1 - x0, y1 - y0)
    top = 28 if a.title else 4
    height = round((y1 - y0) * scale) + top + 24

    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{a.width + 8}" height="{height}" '
             f'viewBox="0 0 {a.width + 8} {height}" font-family="sans-serif" font-size="12">',
             f'<rect width="100%" height="100%" fill="white"/>']
    if a.title:
        parts.append(f'<text x="4" y="18">{html.escape(a.title)}</text>')
    parts.append(f'<g stroke="#1a1a1a" stroke-width="0.25" stroke-linejoin="round">')
    points = cut.GetPoints()
    for i in range(cut.GetNumberOfCells()):
        ids = cut.GetCell(i).GetPointIds()
        n = ids.GetNumberOfIds()
        if n < 3:
            continue
        xy, f = [], 0.0
        for k in range(n):
            pid = ids.GetId(k)
            x, y, _ = points.GetPoint(pid)
            # y grows downwards in SVG: flip so the picture has y up.
            xy.append(f"{4 + (x - x0) * scale:.1f},{top + (y1 - y) * scale:.1f}")
            f += field.GetValue(pid)
        fill = colour((f / n - lo) / (hi - lo) if hi > lo else 0.5)
        parts.append(f'<polygon points="{" ".join(xy)}" fill="{fill}"/>')
    parts.append("</g>")
    parts.append(f'<text x="4" y="{height - 6}">{cut.GetNumberOfCells():,} cut cells of '
                 f'{grid.GetNumberOfCells():,} tetrahedra; field {lo:g} (dark) .. {hi:g} (light)</text>')
    parts.append("</svg>")
    with open(a.svg, "w") as out:
        out.write("\n".join(parts) + "\n")


if __name__ == "__main__":
    main()
