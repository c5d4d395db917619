#!/usr/bin/env python3
"""Reads NRRD files with VTK's vtkNrrdReader and prints what VTK sees.

Used by tests/storage/volume/nrrd_writer_test.cc to check files written by
WriteNrrd / WriteRawWithNhdr with an independent reader. One line per file:

    <dim x> <dim y> <dim z> <spacing x> <spacing y> <spacing z> <count> <values...>

Values are printed with repr(), which round-trips doubles exactly. Exits
with 77 when VTK cannot be imported (the test then skips), 1 when VTK
produced no scalars for a file.
"""
import sys

try:
    from vtkmodules.vtkIOImage import vtkNrrdReader
except ImportError as error:
    print(f"cannot import VTK: {error}", file=sys.stderr)
    sys.exit(77)

for path in sys.argv[1:]:
    reader = vtkNrrdReader()
    reader.SetFileName(path)
    reader.Update()
    image = reader.GetOutput()
    scalars = image.GetPointData().GetScalars()
    if scalars is None:
        print(f"{path}: VTK read no scalars", file=sys.stderr)
        sys.exit(1)
    fields = [str(d) for d in image.GetDimensions()]
    fields += [repr(s) for s in image.GetSpacing()]
    fields.append(str(scalars.GetNumberOfTuples()))
    fields += [repr(scalars.GetTuple1(i)) for i in range(scalars.GetNumberOfTuples())]
    print(" ".join(fields))
