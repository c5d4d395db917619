"""VTK's own readings of the unstructured grids the Python tests check (the
package's meshes and the .vtu files written): an independent reader, not
the code under test. Needs python3-vtk9."""
import numpy as np


def read_vtu(path):
    """The grid in `path` as VTK's XML reader reads it."""
    from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridReader
    reader = vtkXMLUnstructuredGridReader()
    reader.SetFileName(str(path))
    reader.Update()
    return reader.GetOutput()


def volumes(grid):
    """Each cell's signed volume as VTK's vtkCellSizeFilter computes it
    (negative for an inverted tetrahedron), as a numpy array."""
    from vtkmodules.vtkFiltersVerdict import vtkCellSizeFilter
    sizes = vtkCellSizeFilter()
    sizes.SetInputData(grid)
    sizes.ComputeVolumeOn()
    sizes.Update()
    v = sizes.GetOutput().GetCellData().GetArray("Volume")
    return np.array([v.GetValue(i) for i in range(v.GetNumberOfTuples())])
