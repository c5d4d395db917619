#!/usr/bin/env python3
"""Reads a .vtu with VTK's own XML reader and prints what VTK sees, as JSON:

    {"points", "cells", "cell_types": [...distinct...], "point_arrays": {name: [min, max]},
     "cell_arrays": {name: [min, max]}, "volume": total cell volume (unsigned),
     "signed_volume": the sum of VTK's signed cell volumes, "negative_cells": cells
     VTK finds inverted, "bounds": [xmin, xmax, ymin, ymax, zmin, zmax],
     "nan_points": points whose "field" is NaN (a missing value)}

Used by tests/tools/extract_cli_test.cc to check the files `simplexdb
extract --format vtu` writes with an independent reader. Exits 77 when VTK
cannot be imported (the test then skips).
"""
import json
import math
import sys

try:
    from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridReader
    from vtkmodules.vtkFiltersVerdict import vtkCellSizeFilter
except ImportError as error:
    print(f"cannot import VTK: {error}", file=sys.stderr)
    sys.exit(77)

reader = vtkXMLUnstructuredGridReader()
reader.SetFileName(sys.argv[1])
reader.Update()
grid = reader.GetOutput()
if grid is None or grid.GetNumberOfCells() == 0:
    print(f"{sys.argv[1]}: VTK read no cells", file=sys.stderr)
    sys.exit(1)


def arrays(data):
    out = {}
    for i in range(data.GetNumberOfArrays()):
        a = data.GetArray(i)
        out[a.GetName()] = list(a.GetRange())
    return out


sizes = vtkCellSizeFilter()
sizes.SetInputData(grid)
sizes.ComputeVolumeOn()
sizes.Update()
volume = sizes.GetOutput().GetCellData().GetArray("Volume")
values = [volume.GetValue(i) for i in range(volume.GetNumberOfTuples())]
total = sum(abs(v) for v in values)
types = sorted({grid.GetCellType(i) for i in range(grid.GetNumberOfCells())})
field = grid.GetPointData().GetArray("field")
nan_points = 0
if field is not None:
    nan_points = sum(1 for i in range(field.GetNumberOfTuples()) if math.isnan(field.GetValue(i)))
print(json.dumps({
    "points": grid.GetNumberOfPoints(),
    "cells": grid.GetNumberOfCells(),
    "cell_types": types,
    "point_arrays": arrays(grid.GetPointData()),
    "cell_arrays": arrays(grid.GetCellData()),
    "volume": total,
    "signed_volume": sum(values),
    "negative_cells": sum(1 for v in values if v < 0),
    "bounds": list(grid.GetBounds()),
    "nan_points": nan_points,
}))
