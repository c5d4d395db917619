#!/usr/bin/env python3
"""Reads a .vtu with VTK's own XML reader and prints what VTK sees, as JSON:

    {"points", "cells", "cell_types": [...distinct...], "point_arrays": {name: [min, max]},
     "cell_arrays": {name: [min, max]}, "volume": total cell volume (unsigned),
     "signed_volume": the sum of VTK's signed cell volumes, "negative_cells": cells
     VTK finds inverted, "bounds": [xmin, xmax, ymin, ymax, zmin, zmax],
     "nan_points": points whose "field" is NaN (a missing value),
     "file": how the file stores its arrays, read from its XML and the
       compression headers: {"compressor", "header_type", "encoding" (of the
       appended data), "arrays": {name ("Points" for the points): {"type",
       "blocks", "block_size", "last_block_size"}}} (the block fields only
       for zlib-compressed appended arrays with UInt64 headers)}

    vtk_read_vtu.py FILE.vtu [--arrays]

--arrays adds "values": every array as VTK read it, in order: "points"
(x, y, z per point), "field", "error", "level", "code", "connectivity",
"offsets" (VTK's, from 0: cells + 1 of them) and "types"; Float64 values as
the integers of their bits, so a comparison is exact.

Used by tests/tools/extract_cli_test.cc and tests/query/vtu_test.cc to
check the files `simplexdb extract --format vtu` writes with an independent
reader. Exits 77 when VTK cannot be imported (the test then skips).
"""
import json
import math
import re
import struct
import sys

try:
    from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridReader
    from vtkmodules.vtkFiltersVerdict import vtkCellSizeFilter
except ImportError as error:
    print(f"cannot import VTK: {error}", file=sys.stderr)
    sys.exit(77)

path = sys.argv[1]
reader = vtkXMLUnstructuredGridReader()
reader.SetFileName(path)
reader.Update()
grid = reader.GetOutput()
if grid is None or grid.GetNumberOfCells() == 0:
    print(f"{path}: VTK read no cells", file=sys.stderr)
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


def file_format():
    """The VTKFile element's attributes and each array's type and blocks."""
    with open(path, "rb") as f:
        data = f.read()
    start = data.find(b"<AppendedData")
    head = data[:start if start >= 0 else len(data)].decode("utf-8", "replace")

    def attributes(element):
        return dict(re.findall(r'(\w+)="([^"]*)"', element))

    top = attributes(re.search(r"<VTKFile[^>]*>", head).group(0))
    out = {"compressor": top.get("compressor"), "header_type": top.get("header_type"), "encoding": None,
           "arrays": {}}
    appended = None
    if start >= 0:
        tag = data[start:data.find(b">", start) + 1].decode()
        out["encoding"] = attributes(tag).get("encoding")
        appended = data.find(b"_", start + len(tag)) + 1
    for element in re.findall(r"<DataArray[^>]*>", head):
        a = attributes(element)
        name = a.get("Name", "Points")
        entry = {"type": a.get("type")}
        if (a.get("format") == "appended" and appended is not None and out["compressor"]
                and out["header_type"] == "UInt64"):
            at = appended + int(a["offset"])
            entry["blocks"], entry["block_size"], entry["last_block_size"] = struct.unpack_from("<3Q", data, at)
        out["arrays"][name] = entry
    return out


def array_values(array, as_bits=False):
    """The array's values as a list; Float64 as the integers of their bits."""
    if array is None:
        return None
    raw = bytes(memoryview(array))
    if as_bits:
        return list(struct.unpack(f"<{len(raw) // 8}Q", raw))
    return [array.GetValue(i) for i in range(array.GetNumberOfValues())]


result = {
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
    "file": file_format(),
}
if "--arrays" in sys.argv[2:]:
    cells = grid.GetCells()
    result["values"] = {
        "points": array_values(grid.GetPoints().GetData(), as_bits=True),
        "field": array_values(grid.GetPointData().GetArray("field"), as_bits=True),
        "error": array_values(grid.GetCellData().GetArray("error"), as_bits=True),
        "level": array_values(grid.GetCellData().GetArray("level")),
        "code": array_values(grid.GetCellData().GetArray("code")),
        "connectivity": array_values(cells.GetConnectivityArray()),
        "offsets": array_values(cells.GetOffsetsArray()),
        "types": array_values(grid.GetCellTypesArray()),
    }
print(json.dumps(result))
