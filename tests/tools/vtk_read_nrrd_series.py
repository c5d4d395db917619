#!/usr/bin/env python3
"""Reads what `simplexdb export` wrote with VTK and prints what VTK sees.

Used by tests/tools/export_cli_test.cc. Each argument is a .pvd collection
(parsed with the standard library: VTK's Python has no collection reader;
each DataSet's file, relative to the .pvd's folder, is read with
vtkNrrdReader, or vtkXMLImageDataReader for a .vti) or a single image file
(time printed as "-"). One line per image:

    <time> <dim x> <dim y> <dim z> <spacing x y z> <origin x y z> <components> <count> <values...>

Values are printed with repr(), which round-trips doubles exactly. Exits
with 77 when VTK cannot be imported (the test then skips), 1 when VTK
produced no scalars for a file.
"""
import os
import sys
import xml.etree.ElementTree as ElementTree

try:
    from vtkmodules.vtkIOImage import vtkNrrdReader
    from vtkmodules.vtkIOXML import vtkXMLImageDataReader
except ImportError as error:
    print(f"cannot import VTK: {error}", file=sys.stderr)
    sys.exit(77)


def images(path):
    if not path.endswith(".pvd"):
        yield "-", path
        return
    root = ElementTree.parse(path).getroot()
    if root.get("type") != "Collection":
        print(f"{path}: not a VTK Collection", file=sys.stderr)
        sys.exit(1)
    for dataset in root.iter("DataSet"):
        yield dataset.get("timestep"), os.path.join(os.path.dirname(path), dataset.get("file"))


for arg in sys.argv[1:]:
    for time, path in images(arg):
        reader = vtkXMLImageDataReader() if path.endswith(".vti") else vtkNrrdReader()
        reader.SetFileName(path)
        reader.Update()
        image = reader.GetOutput()
        scalars = image.GetPointData().GetScalars()
        if scalars is None:
            print(f"{path}: VTK read no scalars", file=sys.stderr)
            sys.exit(1)
        fields = [time] + [str(d) for d in image.GetDimensions()]
        fields += [repr(s) for s in image.GetSpacing()]
        fields += [repr(o) for o in image.GetOrigin()]
        fields.append(str(scalars.GetNumberOfComponents()))
        fields.append(str(scalars.GetNumberOfTuples()))
        fields += [repr(scalars.GetTuple1(i)) for i in range(scalars.GetNumberOfTuples())]
        print(" ".join(fields))
