"""Store.info against `simplexdb info --json`, Mesh.save's formats (.vtu,
.pvd) read back by VTK, and Mesh.to_pyvista.

Run by ctest (label python) as test_simplexdb.py is: SIMPLEXDB_CLI names the
`simplexdb` tool of the same build and PYTHONPATH holds the built package.
"""
import json
import sys
import types
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import simplexdb
from cli import run
from vtk_grids import read_vtu, volumes



@pytest.fixture(scope="module")
def stores(tmp_path_factory):
    """Dense and sparse stores of an HT (a grid that is not 2^k + 1, with a
    physical spacing and origin) and of an HP (placed in time too)."""
    d = tmp_path_factory.mktemp("stores")
    rng = np.random.default_rng(11)
    rng.integers(0, 256, size=(19, 12, 21), dtype=np.uint8).tofile(d / "v.raw")  # z, y, x on disk
    (d / "v.nhdr").write_text("NRRD0004\ntype: uint8\ndimension: 3\nsizes: 21 12 19\nspacings: 0.5 2 1.5\n"
                              "space origin: (1,-2,3)\nencoding: raw\ndata file: v.raw\n\n")
    run("import", d / "v.nhdr", "-o", d / "ht.sdb", "-q")
    run("import", d / "v.nhdr", "--sparse", "-o", d / "ht.lmdb", "-q")
    run("generate", "--field", "perlin", "--dims", "9,9,9,9", "--type", "uint8", "-q", "-o", d / "hp.nrrd")
    # Time step 0.25 from t = 10: slice 2 (grid units) is physical time 10.5.
    run("import", d / "hp.nrrd", "--spacing", "1,1,1,0.25", "--origin", "0,0,0,10", "-o", d / "hp.sdb", "-q")
    run("import", d / "hp.nrrd", "--spacing", "1,1,1,0.25", "--origin", "0,0,0,10", "--sparse",
        "-o", d / "hp.lmdb", "-q")
    return d


@pytest.mark.parametrize("name", ["ht.sdb", "ht.lmdb", "hp.sdb", "hp.lmdb"])
def test_info_is_what_the_command_prints(stores, name):
    path = str(stores / name)
    store = simplexdb.open(path)
    # The same builder (ops/store_info.h) and the same JSON text: equal
    # exactly, floats included, keys in the same order.
    from_cli = json.loads(run("info", path, "--json"))
    assert store.info == from_cli
    assert list(store.info) == list(from_cli)
    dense = name.endswith(".sdb")
    hierarchy = "ht" if name.startswith("ht") else "hp"
    assert store.info["kind"] == f"{hierarchy}-{'dense' if dense else 'sparse'}"
    assert store.info["path"] == store.info["store"] == path
    assert store.info["dimension"] == store.dimension == (3 if hierarchy == "ht" else 4)
    # What Store reads from it.
    if hierarchy == "ht":
        assert store.dims == (21, 12, 19)
        assert store.spacing == (0.5, 2.0, 1.5)
        assert store.origin == (1.0, -2.0, 3.0)
    else:
        assert store.dims == (9, 9, 9, 9)
        assert store.spacing == (1.0, 1.0, 1.0, 0.25)
        assert store.origin == (0.0, 0.0, 0.0, 10.0)
    assert store.field_range == (from_cli["field_min"], from_cli["field_max"])
    assert ("stored_blocks" in store.info) == dense and ("kept" in store.info) == (not dense)


def read_pvd(path):
    """[(timestep, .vtu path)] of a ParaView collection. VTK 9.1's Python
    has no .pvd reader (vtkPVDReader is ParaView's), so its XML is read here
    and each data set by VTK's own .vtu reader, as ParaView does."""
    root = ET.parse(path).getroot()
    assert root.tag == "VTKFile" and root.get("type") == "Collection"
    sets = root.find("Collection").findall("DataSet")
    assert all(s.get("part") == "0" for s in sets)
    return [(float(s.get("timestep")), path.parent / s.get("file")) for s in sets]


def test_save_pvd_of_an_ht(stores, tmp_path):
    mesh = simplexdb.open(stores / "ht.sdb").extract("4%")
    assert mesh.time is None
    mesh.save(tmp_path / "tooth & co.pvd")  # a name XML must escape
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tooth & co.pvd", "tooth & co.vtu"]
    [(time, vtu)] = read_pvd(tmp_path / "tooth & co.pvd")
    assert time == 0 and vtu == tmp_path / "tooth & co.vtu"
    grid = read_vtu(vtu)
    assert grid.GetNumberOfCells() == len(mesh.cells) > 0
    assert volumes(grid).min() > 0
    # Placed physically: origin (1, -2, 3), extent (20, 11, 18) x spacing (0.5, 2, 1.5).
    assert grid.GetBounds() == (1, 11, -2, 20, 3, 30)
    assert volumes(grid).sum() == pytest.approx(10 * 22 * 27)
    # The .vtu beside the collection is the one save(.vtu) writes.
    mesh.save(tmp_path / "alone.vtu")
    assert vtu.read_bytes() == (tmp_path / "alone.vtu").read_bytes()


@pytest.mark.parametrize("name", ["hp.sdb", "hp.lmdb"])
def test_save_pvd_of_an_hp_slice_is_what_extract_writes(stores, tmp_path, name):
    store = simplexdb.open(stores / name)
    mesh = store.extract("5%", time=2)
    assert mesh.time == 10.5  # origin 10 + 2 x spacing 0.25
    mesh.save(tmp_path / "slice.pvd")
    [(time, vtu)] = read_pvd(tmp_path / "slice.pvd")
    assert time == 10.5 and vtu.name == "slice.vtu"
    grid = read_vtu(vtu)
    assert grid.GetNumberOfCells() == len(mesh.cells) > 0
    assert volumes(grid).min() > 0
    assert volumes(grid).sum() == pytest.approx(8 ** 3)
    # The command's series of one slice: the same time, the same .vtu bytes.
    run("extract", stores / name, "--error", "5%", "--slices", "2", "-o", tmp_path / "cli.pvd")
    [(cli_time, cli_vtu)] = read_pvd(tmp_path / "cli.pvd")
    assert cli_time == time
    assert cli_vtu.read_bytes() == vtu.read_bytes()


def test_save_refuses_other_extensions(stores, tmp_path):
    mesh = simplexdb.open(stores / "ht.sdb").extract("10%")
    for name in ("mesh.vtk", "mesh.pvd.txt", "mesh"):
        with pytest.raises(ValueError, match=r"mesh[.a-z]*: a mesh is saved as \.vtu .* or \.pvd"):
            mesh.save(tmp_path / name)
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(OSError, match="nowhere"):
        mesh.save(tmp_path / "nowhere" / "mesh.pvd")
    pentatopes = simplexdb.open(stores / "hp.sdb").extract("10%")
    with pytest.raises(ValueError, match="time slice"):
        pentatopes.save(tmp_path / "p.pvd")


def test_to_pyvista_wraps_the_vtk_grid(stores, monkeypatch):
    """PyVista is not a Debian package, so a stand-in module records what
    pyvista.wrap is handed."""
    received = []
    stand_in = types.ModuleType("pyvista")
    stand_in.wrap = lambda obj: received.append(obj) or ("wrapped", obj)
    monkeypatch.setitem(sys.modules, "pyvista", stand_in)
    mesh = simplexdb.open(stores / "ht.sdb").extract("4%")
    tag, grid = mesh.to_pyvista()
    assert tag == "wrapped" and received == [grid]
    assert grid.GetClassName() == "vtkUnstructuredGrid"
    assert grid.GetNumberOfCells() == len(mesh.cells)
    assert grid.GetPointData().GetArray("field").GetNumberOfTuples() == len(mesh.points)


def test_to_pyvista_without_pyvista_says_how_to_install_it(stores, monkeypatch):
    monkeypatch.setitem(sys.modules, "pyvista", None)  # `import pyvista` raises ImportError
    mesh = simplexdb.open(stores / "ht.sdb").extract("4%")
    with pytest.raises(ImportError, match="virtual environment.*pip install pyvista"):
        mesh.to_pyvista()
