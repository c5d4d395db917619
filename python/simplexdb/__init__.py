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
    surface = store.isosurface(500, error="1%")   # marching tetrahedra over the leaves
    surface.points, surface.triangles       # numpy arrays; .normals, .error
    surface.save("bone.vtp")                # or .ply, as `simplexdb isosurface` writes

    store = simplexdb.import_volume(array, "v.sdb")   # numpy (Z, Y, X) C order, or a file
    store.export(roi=None, step=1)          # the grid as a (Z, Y, X) array: the array back
    store.export(out="v.nrrd")              # the files `simplexdb export -o v.nrrd` writes
    store.field_at(points)                  # N x 3 (HP: N x 4) physical coordinates
    simplexdb.convert("v.sdb", "v.lmdb", to="sparse", tolerance="1%")  # as `simplexdb convert`
    simplexdb.codes("ht", ["2:10011"])      # what `simplexdb codes` prints, as dicts

Each call runs the same library function (and the same checks) as the
command it names: the options' errors name the option as the command spells
it ("--error: expected a number >= 0 ...").

Stores are the files `simplexdb import` writes (dense .sdb or sparse LMDB,
HT for 3D volumes, HP for 3D fields over time). Errors raise ValueError for
bad arguments and OSError for files that are missing, unreadable or
damaged, with SimplexDB's message.

Threads: a store may be queried from several threads at once; the GIL is
released while a store opens, while a query runs and while import_volume
builds.

Arrays: every array of a Mesh is a numpy view of the buffer the C++ query
filled, handed over without a copy; numpy owns it from then on.
"""

import os as _os
import sys as _sys

from . import _simplexdb

__all__ = ["open", "Store", "Mesh", "Surface"]


def _path(value, what):
    """A file name as text: a str, bytes or os.PathLike (decoded as the
    file system does); ValueError for anything else and for a NUL byte,
    which no file name holds."""
    try:
        path = _os.fsdecode(value)
    except TypeError:
        raise ValueError(f"{what}: expected a file name (str, bytes or a path), not {value!r}") from None
    if "\0" in path:
        raise ValueError(f"{what}: {path!r} holds a NUL byte, which no file name can")
    return path


def _text(value, what):
    """A string option (an algorithm's name, a source's description)."""
    if not isinstance(value, str):
        raise ValueError(f"{what}: expected a string, not {value!r}")
    return value


def _whole(value, what, lo, hi):
    """A whole number in [lo, hi] (an int, or a float or numpy integer
    holding one): what the C++ side's type holds; its value the library
    checks, with the command's words."""
    try:
        ok = int(value) == value and lo <= int(value) <= hi
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok:
        raise ValueError(f"{what}: expected a whole number from {lo} to {hi}, not {value!r}")
    return int(value)


def _amount(value, what):
    """7.3 (field units) or "1%" (of the field range), as the C++ side reads
    it (ops/amount.h): text is passed as text, anything else as a float."""
    if isinstance(value, str):
        return value.strip()
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{what}: expected a number >= 0 such as 7.3 or '1%', not {value!r}") from None


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
        _simplexdb.save_mesh(_path(path, "path"), self.points, self.cells, self.field, self.error, self.level,
                             self.cell_codes, 0.0 if self.time is None else self.time)

    def to_pyvista(self):
        """The tetrahedra as a pyvista.UnstructuredGrid: pyvista.wrap of
        to_vtk(). Needs PyVista, which Debian does not package (install it
        in a virtual environment): ImportError saying so without it."""
        self._require_tetrahedra("to_pyvista")
        try:
            import pyvista
        except ImportError as e:
            raise ImportError("Mesh.to_pyvista needs PyVista, which is not installed and which Debian does not "
                              "package (its pip refuses to install into the system's Python): in a virtual "
                              "environment, python3 -m venv --system-site-packages env && env/bin/pip install "
                              "pyvista; or Mesh.to_vtk(), the same grid as VTK's vtkUnstructuredGrid") from e
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


class Surface:
    """The result of Store.isosurface: a watertight triangle mesh (but where
    it leaves the grid), as `simplexdb isosurface` writes it.

    points      numpy float64, N x 3: physical coordinates
    normals     numpy float32, N x 3: the field's unit gradient at each point
                (toward increasing values; zeros where it vanishes)
    triangles   numpy int64, M x 3: point indices, oriented so that their
                normals point toward increasing values
    error       numpy float64, M: the error bound of each triangle's tetrahedron
    stats       dict: the statistics (as `isosurface --json`)
    """

    def __init__(self, result):
        self.points = result["points"]
        self.normals = result["normals"]
        self.triangles = result["triangles"]
        self.error = result["error"]
        self.stats = result["stats"]
        self._comment = result["comment"]  # the .ply header's, as the command writes it

    def __repr__(self):
        return f"<simplexdb.Surface: {len(self.triangles):,} triangles, {len(self.points):,} points>"

    def save(self, path):
        """Writes the surface, the format named by the extension: .vtp (VTK
        XML PolyData, for ParaView) or .ply (binary). ValueError for another
        extension; OSError when writing fails (nothing is left under the
        name then)."""
        _simplexdb.save_surface(_path(path, "path"), self.points, self.normals, self.triangles, self.error,
                                self._comment)

    def to_vtk(self):
        """The surface as a vtkPolyData with point data "Normals" and cell
        data "error" (needs VTK: Debian's python3-vtk9)."""
        import numpy as np
        from vtkmodules.util import numpy_support
        from vtkmodules.vtkCommonCore import vtkPoints
        from vtkmodules.vtkCommonDataModel import vtkCellArray, vtkPolyData

        poly = vtkPolyData()
        points = vtkPoints()
        points.SetData(numpy_support.numpy_to_vtk(self.points, deep=True))
        poly.SetPoints(points)
        offsets = np.arange(0, 3 * len(self.triangles) + 1, 3, dtype=np.int64)
        cells = vtkCellArray()
        cells.SetData(numpy_support.numpy_to_vtkIdTypeArray(offsets, deep=True),
                      numpy_support.numpy_to_vtkIdTypeArray(self.triangles.reshape(-1).astype(np.int64), deep=True))
        poly.SetPolys(cells)
        normals = numpy_support.numpy_to_vtk(self.normals, deep=True)
        normals.SetName("Normals")
        poly.GetPointData().SetNormals(normals)
        error = numpy_support.numpy_to_vtk(self.error, deep=True)
        error.SetName("error")
        poly.GetCellData().AddArray(error)
        return poly


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

    def extract(self, error, box=None, iso=None, time=None, algorithm="depth-first", budget=None, mesh=True,
                units="grid", previous=None, piece=None, pieces=None):
        """Selective refinement, as `simplexdb extract`: the minimal
        conforming mesh whose simplices meeting the criteria have error <=
        `error` (a float in field units, or a string like "1%" of the field
        range). `box` is (x0, y0, z0, x1, y1, z1[, t0, t1]), `iso` an
        isovalue, `time` (HP) the time slice; box and time in grid units, or
        physical ones with units="physical". `algorithm` as the command's
        (incremental refines `previous`, a Mesh of this store, when given).
        `mesh=False` skips the tetrahedra (codes and statistics only).

        `piece` and `pieces` (both or neither): only piece `piece` (from 0)
        of the mesh cut in `pieces`, the same part MPI rank `piece` of an
        `mpirun -np PIECES simplexdb extract` writes; the pieces' union is
        the whole mesh, cell for cell. Depth-first only. This process walks
        every piece to learn the splits that cross into this one, so a
        piece costs about the whole mesh here: spreading the work over
        processes is mpirun's."""
        if (piece is None) != (pieces is None):
            raise ValueError("piece and pieces: give both (piece r of pieces n) or neither")
        if pieces is not None:
            for name, v in (("piece", piece), ("pieces", pieces)):
                if isinstance(v, bool) or not isinstance(v, int):
                    raise ValueError(f"{name}: expected a whole number, not {v!r}")
        if box is not None:
            box = [float(x) for x in box]
        if budget is not None:
            try:
                ok = int(budget) == budget and 1 <= int(budget) < 2**64
            except (TypeError, ValueError, OverflowError):
                ok = False
            if not ok:
                raise ValueError(f"budget: expected a whole number of simplices >= 1, not {budget!r}")
            budget = int(budget)
        algorithm = _text(algorithm, "algorithm")
        units = _text(units, "units")
        if previous is not None and not isinstance(previous, Mesh):
            raise ValueError(f"previous: expected a Mesh this store's extract returned, not {previous!r}")
        result = _simplexdb.extract(self._core, _amount(error, "error"), box, None if iso is None else float(iso),
                                    None if time is None else float(time), str(units), algorithm,
                                    0 if budget is None else int(budget),
                                    None if previous is None else [int(k) for k in previous.codes], bool(mesh),
                                    0 if piece is None else piece, 1 if pieces is None else pieces)
        return Mesh(self.dimension, result)

    def isosurface(self, iso, error="1%", box=None, time=None, units="grid"):
        """The surface where the field equals `iso`, as `simplexdb
        isosurface`: marching tetrahedra over the leaves extract(error,
        iso=iso, box=box, time=time) gives, never collecting them; every
        point's full-resolution value is within `error` of `iso` (inside
        `box`, when given). An HP's surface is that of the time slice
        `time` (required). Returns a Surface."""
        if isinstance(iso, bool) or not isinstance(iso, (int, float)) and not hasattr(iso, "__float__"):
            raise ValueError(f"iso: expected a number in field units, not {iso!r}")
        if box is not None:
            box = [float(x) for x in box]
        units = _text(units, "units")
        result = _simplexdb.isosurface(self._core, float(iso), _amount(error, "error"), box,
                                       None if time is None else float(time), str(units))
        return Surface(result)

    def export(self, roi=None, step=1, time=None, out=None, force=False):
        """The field on the grid, as `simplexdb export` writes it: a C-order
        numpy array of shape (Z, Y, X) (HP: (T, Z, Y, X); with `time`, that
        one time step's (Z, Y, X)), of the store's voxel type, so that
        export() of a store import_volume built from a C-order array `a`
        equals `a`. `roi` is a box of grid indices, inclusive, x first: (x0,
        y0, z0, x1, y1, z1) (HP: (x0, y0, z0, t0, x1, y1, z1, t1); with
        `time`, the three space axes); `step` takes every step-th point
        along each axis. A sparse store gives its rebuilt values (exact when
        lossless; integer types rounded and clamped to the type's range, as
        `convert --to dense` does: a lossy store may rebuild a 0 of uint8 as
        -1).

        With `out`, writes the files `simplexdb export STORE -o OUT` writes
        instead (OUT.nrrd, OUT.raw + OUT.nhdr, or for an HP without `time`
        a series named by OUT.nrrd or OUT.pvd) and returns what was written,
        as the command says it; `force` as the command's --force."""
        import numpy as np
        if isinstance(step, bool) or not isinstance(step, (int, np.integer)) or step < 1:
            raise ValueError(f"step: expected a whole number >= 1, not {step!r}")
        if roi is not None:
            roi = list(roi)
            if any(isinstance(x, bool) or not isinstance(x, (int, np.integer)) for x in roi):
                raise ValueError(f"roi: expected whole grid indices, not {roi!r}")
            roi = [float(x) for x in roi]
        if time is not None:
            if isinstance(time, bool) or not isinstance(time, (int, np.integer)):
                raise ValueError(f"time: expected a whole time step, not {time!r}")
            time = float(time)
        if out is not None:
            return _simplexdb.export_file(self._core, _path(out, "out"), roi, int(step), time, bool(force))
        values = _simplexdb.export(self._core, roi, int(step), time)
        # Every value is one the voxel type holds (rounded and clamped in C++).
        return values.astype(np.dtype(_simplexdb.voxel_type(self._core)))

    def verify(self):
        """Checks every checksum and invariant, as `simplexdb verify`:
        returns what was checked ({"kind", "blocks", "bricks" or "kept"});
        OSError naming the first bad block otherwise."""
        return _simplexdb.verify(self._core)

    def field_at(self, points, units="physical"):
        """The field at `points`, an N x 3 (HP: N x 4) array of x, y, z[, t]
        in physical coordinates (origin + spacing x grid, as Mesh.points) or,
        with units="grid", in grid indices; numpy float64 of length N. The
        field is the store's full-resolution one, interpolated linearly over
        the finest simplex of the hierarchy that holds the point: exact at
        grid points, between a grid cell's corner values inside it. A point
        outside the grid raises ValueError naming it and the range."""
        import numpy as np
        if units not in ("physical", "grid"):
            raise ValueError(f"units: expected 'physical' or 'grid', not {units!r}")
        p = np.array(points, dtype=np.float64, ndmin=2)
        if p.ndim != 2 or p.shape[1] != self.dimension:
            raise ValueError(f"points: expected an N x {self.dimension} array, got shape {p.shape}")
        if units == "physical":
            origin, spacing = np.asarray(self.origin), np.asarray(self.spacing)
            grid = (p - origin) / spacing
            last = origin + spacing * (np.asarray(self.dims) - 1)
            outside = ~np.all((grid >= -1e-9) & (grid <= np.asarray(self.dims) - 1 + 1e-9), axis=1)
            if outside.any():
                bad = tuple(float(x) for x in p[np.argmax(outside)])
                # Smaller first: a flipped axis (negative spacing) runs backwards.
                ranges = ", ".join(f"{min(lo, hi):g}..{max(lo, hi):g}" for lo, hi in zip(origin, last))
                raise ValueError(f"{self.info['path']}: point {bad} is outside the grid ({ranges}, physical units)")
            p = grid
            # Physical coordinates of grid points round-trip to within an ulp.
            near = np.rint(p)
            p = np.where(np.abs(p - near) <= 1e-9 * np.maximum(1, np.abs(near)), near, p)
        return _simplexdb.field_at(self._core, p)


def open(path, cache_mb=256, in_memory=False):  # noqa: A001 (the package's verb, as io.open)
    """Opens the store at `path` (dense or sparse, HT or HP). `cache_mb`
    bounds the decoded blocks kept; `in_memory` decodes a dense store whole
    at open (in-core queries). OSError, with the reason, for a file that is
    missing, unreadable, not a store, damaged or of another format."""
    path = _path(path, "path")
    try:
        cache_mb = float(cache_mb)
    except (TypeError, ValueError):
        raise ValueError(f"cache_mb: expected a size in MiB >= 0, not {cache_mb!r}") from None
    return Store(_simplexdb.open(path, cache_mb, bool(in_memory)))


_DTYPES = {"uint8", "int8", "uint16", "int16", "float32", "float64"}


def _array_layout(a):
    """(contiguous array, dims x first): x is the axis adjacent in memory —
    the last of a C-order array (shape (Z, Y, X) or (T, Z, Y, X)), the first
    of a Fortran-order one (shape (X, Y, Z) or (X, Y, Z, T)), as numpy's
    flags say. Other layouts (strided, flipped or broadcast views) are
    copied: in Fortran order when the strides of the axes that move in
    memory (not 0, not of length 1) grow from the first axis to the last,
    else in C order, numpy's own (a broadcast view with no such order is a
    C-order array of its shape)."""
    import numpy as np
    if a.flags.c_contiguous:
        return a, [int(n) for n in reversed(a.shape)]
    if a.flags.f_contiguous:
        return a, [int(n) for n in a.shape]
    moving = [abs(s) for s, n in zip(a.strides, a.shape) if s != 0 and n > 1]
    if len(moving) > 1 and all(x < y for x, y in zip(moving, moving[1:])):
        return np.asfortranarray(a), [int(n) for n in a.shape]
    return np.ascontiguousarray(a), [int(n) for n in reversed(a.shape)]


def import_volume(array_or_path, out, hierarchy=None, quantization="u16", compression="zstd",
                  spacing=None, origin=None, sparse=False, progress=True, *, dims=None, dtype=None,
                  offset=0, source=None, threads=0, tolerance=0):
    """Builds the store `out` as `simplexdb import` does and returns it opened
    (a Store).

    array_or_path: a numpy array of voxels (uint8, int8, uint16, int16,
        float32 or float64; 3 axes for an HT, 4 for an HP), read in place,
        not copied. x is the axis adjacent in memory: a C-order array has
        shape (Z, Y, X) or (T, Z, Y, X), as np.fromfile(f, t).reshape(nz, ny,
        nx) gives; a Fortran-order array has shape (X, Y, Z) or (X, Y, Z, T),
        as nibabel gives. Both import the same as a raw file of dims X,Y,Z
        (and, as for files, 4 axes with one time step are a 3D volume).
        Or a path: NRRD (.nrrd, .nhdr) or NIfTI-1 (.nii), or a raw file with
        `dims` (X, Y, Z[, T], x fastest) and `dtype` (a numpy dtype; '>u2'
        for big-endian), after `offset` header bytes.
    hierarchy: "ht" or "hp", checked against the volume; None: from it.
    quantization: the errors as "u16", "u8" or "f32"; compression: the
        dense store's blocks as "zstd" or "none".
    spacing, origin: one number per axis, x first (as Store.spacing and
        `--spacing`); None: the file's (an array's: 1 and 0).
    sparse: the variable-resolution LMDB store instead of the dense one;
        tolerance: its diamonds within this are dropped (7.3 in field units,
        or "1%" of the range; 0: lossless), as --tolerance.
    progress: the CLI's progress line on stderr.
    source: what the store records as its source (default: the file's
        description, or "numpy array").
    threads: the builder's worker threads (0: one per core). The dense
        store's bricks are laid out in the order the threads finish them:
        the same bytes run after run only with threads=1.
    The GIL is released during the build."""
    import numpy as np
    out = _path(out, "out")
    if source is not None:
        source = _text(source, "source")
    threads = _whole(threads, "threads", -2**31, 2**31 - 1)  # the library checks the count
    offset = _whole(offset, "offset", 0, 2**63 - 1)
    if hierarchy is not None and hierarchy not in ("ht", "hp"):
        raise ValueError(f"hierarchy: expected 'ht', 'hp' or None, not {hierarchy!r}")

    def numbers(values, what):
        if values is None:
            return None
        try:
            return [float(v) for v in values]
        except (TypeError, ValueError):
            raise ValueError(f"{what}: expected one number per axis, x first, not {values!r}") from None

    common = (out, hierarchy or "", str(quantization), str(compression), numbers(spacing, "spacing"),
              numbers(origin, "origin"), bool(sparse), _amount(tolerance, "tolerance"), bool(progress), source)
    if isinstance(array_or_path, (str, bytes, _os.PathLike)):
        path = _path(array_or_path, "array_or_path")
        if dims is None and dtype is None and not path.lower().endswith((".nrrd", ".nhdr", ".nii")):
            raise ValueError(f"{path}: not a .nrrd, .nhdr or .nii file; a raw file needs dims=(X, Y, Z[, T]) "
                             f"and dtype= (a numpy dtype: 'uint8', or '>u2' for big-endian), and offset= for a "
                             f"header to skip")
        if (dims is None) != (dtype is None):
            raise ValueError("a raw file needs both dims (X, Y, Z[, T]) and dtype")
        type_name, endian = "", "little"
        if dtype is not None:
            t = np.dtype(dtype)
            if t.name not in _DTYPES:
                raise ValueError(f"dtype: {t} is not a voxel type SimplexDB reads: expected one of "
                                 f"{', '.join(sorted(_DTYPES))}")
            type_name, endian = t.name, "big" if t.byteorder == ">" else "little"
            try:
                dims = [_whole(d, "dims", 1, 2**32 - 1) for d in dims]
            except TypeError:
                raise ValueError(f"dims: expected X, Y, Z[, T], not {dims!r}") from None
            if len(dims) not in (3, 4):
                raise ValueError(f"dims: expected X, Y, Z[, T], not {dims!r}")
        _simplexdb.import_volume(path, *common, dims, type_name, endian, offset, threads)
        return open(out)
    if dims is not None or dtype is not None or offset:
        raise ValueError("dims, dtype and offset describe a raw file; an array describes itself")
    a = np.asarray(array_or_path)
    if a.dtype.name not in _DTYPES:
        raise ValueError(f"array: dtype {a.dtype} is not a voxel type SimplexDB reads: expected one of "
                         f"{', '.join(sorted(_DTYPES))}")
    if a.ndim not in (3, 4):
        raise ValueError(f"array: expected 3 axes (Z, Y, X) for an HT or 4 (T, Z, Y, X) for an HP, "
                         f"got shape {a.shape}")
    a, grid = _array_layout(a)
    endian = "big" if a.dtype.byteorder == ">" or (a.dtype.byteorder == "=" and _sys.byteorder == "big") \
        else "little"
    _simplexdb.import_volume(a, *common, grid, a.dtype.name, endian, 0, threads)
    return open(out)


def convert(store, out, to, tolerance=0, compression="zstd", memory_mb=1024, threads=0, progress=True):
    """Converts the store at `store` into `out` as `simplexdb convert STORE
    -o OUT --to TO` does, and returns the new store opened. to="sparse":
    from a dense store, dropping the diamonds within `tolerance` (7.3, or
    "1%" of the range; 0: lossless); to="dense": from a sparse store,
    verified first (`compression` of its blocks: "zstd" or "none").
    `memory_mb` bounds the field read into memory (a double a grid point);
    `threads` the builder's (0: one per core; a dense store's bytes repeat
    run after run only with 1). The GIL is released during the conversion."""
    out = _path(out, "out")
    _simplexdb.convert(_path(store, "store"), out, str(to), _amount(tolerance, "tolerance"), str(compression),
                       float(memory_mb), int(threads), bool(progress))
    return open(out)


def codes(hierarchy, codes):  # noqa: A002 (the CLI's name)
    """What `simplexdb codes --hierarchy H` prints for each code, as dicts:
    code, level, vertices (unit-cube coordinates), neighbors, parent,
    children, cluster. `codes` is one code string ("T:bits") or a list of
    them; a string that is not a code raises ValueError naming it."""
    import json
    single = isinstance(codes, str)
    name = str(hierarchy).lower()  # the CLI takes any case
    out = [json.loads(_simplexdb.describe_code(name, str(c))) for c in ([codes] if single else codes)]
    return out[0] if single else out


__all__ += ["import_volume", "convert", "codes"]
