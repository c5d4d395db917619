"""SimplexDB from Python: open a store, extract error-bounded meshes as numpy
arrays, hand them to VTK or write them for ParaView.

    import simplexdb
    store = simplexdb.open("tooth.sdb")
    mesh = store.extract("3%")              # or an error in field units: 7.5
    mesh.points, mesh.cells, mesh.field     # numpy arrays (physical coordinates)
    mesh.save("tooth_3.vtu")                # VTK's XML format, as `simplexdb extract` writes
    mesh.save("tooth_3.pvd")                # the same, in a ParaView collection with its time
    grid = mesh.to_vtk()                    # a vtkUnstructuredGrid (needs VTK)
    grid = mesh.to_pyvista()                # the same as PyVista's grid (needs PyVista)

Stores are the files `simplexdb import` writes (dense .sdb or sparse LMDB,
HT for 3D volumes, HP for 3D fields over time). Errors raise ValueError for
bad arguments and OSError for files that are missing, unreadable or
damaged, with SimplexDB's message.

Threads: a store may be queried from several threads at once; the GIL is
released while a store opens and while a query runs.

Arrays: every array of a Mesh is a numpy view of the buffer the C++ query
filled, handed over without a copy; numpy owns it from then on.
"""

import os as _os

from . import _simplexdb

__all__ = ["open", "Store", "Mesh"]


def _amount(value, what, field_range):
    """7.3 (field units) or "1%" (of the field range) -> field units."""
    if isinstance(value, str):
        text = value.strip()
        percent = text.endswith("%")
        try:
            number = float(text[:-1] if percent else text)
        except ValueError:
            raise ValueError(f"{what}: expected a number >= 0 such as 7.3 or '1%', not {value!r}") from None
        value = number / 100 * field_range if percent else number
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{what}: expected a number >= 0 such as 7.3 or '1%', not {value!r}") from None
    if not value >= 0 or value == float("inf"):
        raise ValueError(f"{what}: expected a number >= 0 such as 7.3 or '1%', not {value!r}")
    return value


class Mesh:
    """The result of Store.extract.

    codes       numpy uint64: the leaves' packed location codes (code_strings()
                gives them as `simplexdb extract --format codes` writes them)
    points      numpy float64, N x 3: physical coordinates (origin + spacing x grid)
    cells       numpy int64, M x 4: point indices, each tetrahedron positively oriented
    field       numpy float64, N: the field at the points
    error       numpy float64, M: each cell's stored error bound
    level       numpy uint8, M: each cell's level in the hierarchy
    stats       dict: the query's statistics (as `extract --format json`)
    time        an HP time slice's physical time (origin[3] + time x spacing[3]);
                None for an HT

    For an HT the tetrahedra are the leaves, clipped to the real grid; for an
    HP they are the time slice `time=` (without it, points and cells are None
    and only the pentatopes' codes are given).
    """

    def __init__(self, dimension, result):
        self.dimension = dimension
        self.codes = result["codes"]
        self.stats = result["stats"]
        self.points = result.get("points")
        self.cells = result.get("cells")
        self.field = result.get("field")
        self.error = result.get("error")
        self.level = result.get("level")
        self.cell_codes = result.get("cell_codes")
        # An HP time slice's physical time (origin[3] + time x spacing[3]);
        # None for an HT and for pentatopes without a slice.
        self.time = result.get("time")

    def __repr__(self):
        tets = "no tetrahedra" if self.cells is None else f"{len(self.cells):,} tetrahedra"
        return f"<simplexdb.Mesh: {len(self.codes):,} leaves, {tets}>"

    def code_strings(self):
        """The leaves' codes as text, "T:bits"."""
        return [_simplexdb.code_string(self.dimension, int(k)) for k in self.codes]

    def _require_tetrahedra(self, what):
        if self.cells is None:
            raise ValueError(f"{what}: an HP mesh has tetrahedra only as a time slice: extract(..., time=T)")

    def save(self, path):
        """Writes the tetrahedra for VTK and ParaView, the format named by
        the extension:
            .vtu  a VTK XML unstructured grid, as `simplexdb extract -o X.vtu`
            .pvd  a ParaView collection (the writer of `simplexdb extract -o
                  X.pvd`) naming X.vtu, written beside it (replacing it), at
                  the mesh's time: an HP slice's physical time, 0 for an HT.
        ValueError for another extension; OSError when writing fails (then
        nothing is left under the name being written)."""
        self._require_tetrahedra("save")
        path = _os.fspath(path)
        if path.endswith(".vtu"):
            vtu = path
        elif path.endswith(".pvd"):
            vtu = path[:-4] + ".vtu"
        else:
            raise ValueError(f"{path}: save writes .vtu (an unstructured grid) or .pvd (a ParaView "
                             f"collection of one .vtu), named by the extension")
        _simplexdb.save_vtu(vtu, self.points, self.cells, self.field, self.error, self.level, self.cell_codes)
        if vtu != path:
            # The .vtu first: the collection never names a missing file.
            _simplexdb.save_pvd(path, [(0.0 if self.time is None else self.time, _os.path.basename(vtu))])

    def to_pyvista(self):
        """The tetrahedra as a pyvista.UnstructuredGrid: pyvista.wrap of
        to_vtk(). Needs PyVista (pip install pyvista; Debian has no package
        of it): ImportError saying so without it."""
        self._require_tetrahedra("to_pyvista")
        try:
            import pyvista
        except ImportError as e:
            raise ImportError("Mesh.to_pyvista needs PyVista, which is not installed: pip install pyvista "
                              "(Debian has no package of it); Mesh.to_vtk() gives the same grid as VTK's "
                              "vtkUnstructuredGrid") from e
        return pyvista.wrap(self.to_vtk())

    def to_vtk(self):
        """The tetrahedra as a vtkUnstructuredGrid with point data "field" and
        cell data "error" and "level" (needs VTK: Debian's python3-vtk9)."""
        self._require_tetrahedra("to_vtk")
        import numpy as np
        from vtkmodules.util import numpy_support
        from vtkmodules.vtkCommonCore import vtkPoints
        from vtkmodules.vtkCommonDataModel import VTK_TETRA, vtkCellArray, vtkUnstructuredGrid

        grid = vtkUnstructuredGrid()
        points = vtkPoints()
        points.SetData(numpy_support.numpy_to_vtk(self.points, deep=True))
        grid.SetPoints(points)
        offsets = np.arange(0, 4 * len(self.cells) + 1, 4, dtype=np.int64)
        cells = vtkCellArray()
        cells.SetData(numpy_support.numpy_to_vtkIdTypeArray(offsets, deep=True),
                      numpy_support.numpy_to_vtkIdTypeArray(self.cells.reshape(-1).astype(np.int64), deep=True))
        grid.SetCells(VTK_TETRA, cells)
        for name, values, data in (("field", self.field, grid.GetPointData()),
                                   ("error", self.error, grid.GetCellData()),
                                   ("level", self.level, grid.GetCellData())):
            array = numpy_support.numpy_to_vtk(values, deep=True)
            array.SetName(name)
            data.AddArray(array)
        grid.GetPointData().SetActiveScalars("field")
        return grid


class Store:
    """An open store: see simplexdb.open."""

    def __init__(self, core):
        self._core = core
        self.info = core.info
        self.dimension = self.info["dimension"]
        self.dims = tuple(self.info["dims"])
        self.spacing = tuple(self.info["spacing"])
        self.origin = tuple(self.info["origin"])
        self.field_range = (self.info["field_min"], self.info["field_max"])

    def __repr__(self):
        dims = "x".join(str(d) for d in self.dims)
        return f"<simplexdb.Store {self.info['path']!r}: {self.info['hierarchy'].upper()} over {dims}>"

    def extract(self, error, box=None, iso=None, time=None, algorithm="depth-first", budget=None, mesh=True):
        """Selective refinement: the minimal conforming mesh whose simplices
        meeting the criteria have error <= `error` (a float in field units,
        or a string like "1%" of the field range). `box` is
        (x0, y0, z0, x1, y1, z1[, t0, t1]) in grid units, `iso` an isovalue,
        `time` (HP) the time slice in grid units. `mesh=False` skips the
        tetrahedra (codes and statistics only)."""
        lo, hi = self.field_range
        threshold = _amount(error, "error", hi - lo)
        if box is not None:
            box = [float(x) for x in box]
        if budget is not None and (int(budget) != budget or budget < 1):
            raise ValueError(f"budget: expected a whole number of simplices >= 1, not {budget!r}")
        result = _simplexdb.extract(self._core, threshold, box, None if iso is None else float(iso),
                                    None if time is None else float(time), algorithm,
                                    0 if budget is None else int(budget), bool(mesh))
        result["stats"]["threshold"] = threshold
        result["stats"]["hierarchy"] = self.info["hierarchy"]
        if time is not None and self.dimension == 4:
            result["time"] = self.origin[3] + float(time) * self.spacing[3]
        return Mesh(self.dimension, result)


def open(path, cache_mb=256, in_memory=False):  # noqa: A001 (the package's verb, as io.open)
    """Opens the store at `path` (dense or sparse, HT or HP). `cache_mb`
    bounds the decoded blocks kept; `in_memory` decodes a dense store whole
    at open (in-core queries)."""
    return Store(_simplexdb.open(_os.fspath(path), float(cache_mb), bool(in_memory)))
