"""The Python package against the command line it must agree with, and VTK.

Run by ctest (label python) with Debian's /usr/bin/python3 -m pytest;
SIMPLEXDB_CLI names the `simplexdb` tool of the same build and PYTHONPATH
holds the built package.
"""
import builtins
import json
import threading

import numpy as np
import pytest

import simplexdb
from cli import run
from vtk_grids import read_vtu, volumes



@pytest.fixture(scope="module")
def stores(tmp_path_factory):
    """An HT store of a grid that is not 2^k + 1 (so meshes are clipped) with
    a physical spacing, its sparse twin, and an HP store."""
    d = tmp_path_factory.mktemp("stores")
    rng = np.random.default_rng(7)
    raw = d / "v.raw"
    rng.integers(0, 256, size=(19, 12, 21), dtype=np.uint8).tofile(raw)  # z, y, x order on disk
    nhdr = d / "v.nhdr"
    nhdr.write_text("NRRD0004\ntype: uint8\ndimension: 3\nsizes: 21 12 19\nspacings: 0.5 2 1.5\n"
                    "encoding: raw\ndata file: v.raw\n\n")
    run("import", nhdr, "-o", d / "ht.sdb", "-q")
    run("import", nhdr, "--sparse", "-o", d / "ht.lmdb", "-q")
    run("generate", "--field", "perlin", "--dims", "9,9,9,9", "--type", "uint8", "-q", "-o", d / "hp.nrrd")
    run("import", d / "hp.nrrd", "-o", d / "hp.sdb", "-q")
    return d


def cli_extract(store, *criteria):
    stats = json.loads(run("extract", store, *criteria, "--format", "json"))
    codes = run("extract", store, *criteria, "--format", "codes").split()
    return stats, codes


@pytest.mark.parametrize("name", ["ht.sdb", "ht.lmdb"])
def test_store_describes_itself(stores, name):
    store = simplexdb.open(stores / name)
    assert store.dimension == 3
    assert store.dims == (21, 12, 19)
    assert store.spacing == (0.5, 2.0, 1.5)
    info = json.loads(run("info", stores / name, "--json"))
    assert store.field_range == (info["field_min"], info["field_max"])


@pytest.mark.parametrize("name", ["ht.sdb", "ht.lmdb"])
@pytest.mark.parametrize("criteria", [("3%",), (0,), ("20%", (2, 2, 2, 10, 6, 9)), ("1%", None, 100.0)])
def test_extract_matches_the_command_line(stores, name, criteria):
    error, box, iso = (list(criteria) + [None, None])[:3]
    args = ["--error", str(error)]
    if box is not None:
        args += ["--box", ",".join(map(str, box))]
    if iso is not None:
        args += ["--iso", str(iso)]
    stats, codes = cli_extract(stores / name, *args)
    mesh = simplexdb.open(stores / name).extract(error, box=box, iso=iso)
    assert mesh.code_strings() == codes
    for key in ("simplices", "splits", "cluster_computations", "candidates", "threshold"):
        assert mesh.stats[key] == stats[key], key
    # The tetrahedra as the .vtu the command writes, read by VTK.
    vtu = stores / f"{name}.vtu"
    run("extract", stores / name, *args, "-o", vtu)
    from_file = read_vtu(vtu)
    grid = mesh.to_vtk()
    assert grid.GetNumberOfCells() == from_file.GetNumberOfCells() == len(mesh.cells)
    assert grid.GetNumberOfPoints() == from_file.GetNumberOfPoints()
    assert grid.GetBounds() == from_file.GetBounds() == (0, 10, 0, 22, 0, 27)
    assert volumes(grid) == pytest.approx(volumes(from_file))
    assert min(volumes(grid)) > 0
    assert sum(volumes(grid)) == pytest.approx(10 * 22 * 27)


def test_save_writes_what_the_command_writes(stores):
    mesh = simplexdb.open(stores / "ht.sdb").extract("5%")
    mesh.save(stores / "saved.vtu")
    run("extract", stores / "ht.sdb", "--error", "5%", "-o", stores / "cli.vtu")
    assert (stores / "saved.vtu").read_bytes() == (stores / "cli.vtu").read_bytes()


def test_hp_time_slice(stores):
    store = simplexdb.open(stores / "hp.sdb")
    assert store.dimension == 4 and store.dims == (9, 9, 9, 9)
    stats, codes = cli_extract(stores / "hp.sdb", "--error", "5%", "--time", "3.5")
    mesh = store.extract("5%", time=3.5)
    assert mesh.code_strings() == codes
    assert len(mesh.cells) == stats["slice_tetrahedra"]
    assert sum(volumes(mesh.to_vtk())) == pytest.approx(8 ** 3)
    pentatopes = store.extract("5%")
    assert pentatopes.cells is None
    with pytest.raises(ValueError, match="time slice"):
        pentatopes.to_vtk()


@pytest.mark.parametrize("name,criteria", [("ht.sdb", {}), ("ht.lmdb", {}), ("ht.sdb", {"box": (2, 2, 2, 10, 6, 9)}),
                                           ("hp.sdb", {"time": 3.5})])
def test_pieces_make_the_mesh(stores, name, criteria):
    """The pieces of extract(piece=r, pieces=n), one after the other, are the
    whole mesh: its codes in order and its cells, none twice."""
    store = simplexdb.open(stores / name)
    whole = store.extract("2%", **criteria)
    for n in (2, 3):
        parts = [store.extract("2%", piece=r, pieces=n, **criteria) for r in range(n)]
        np.testing.assert_array_equal(np.concatenate([p.codes for p in parts]), whole.codes)
        assert all(len(p.codes) > 0 for p in parts)
        assert sum(p.stats["simplices"] for p in parts) == whole.stats["simplices"]
        assert [p.stats["piece"] for p in parts] == list(range(n))
        if whole.cells is not None:
            assert sum(len(p.cells) for p in parts) == len(whole.cells)
            cells = np.concatenate([p.cell_codes for p in parts])
            assert sorted(cells.tolist()) == sorted(whole.cell_codes.tolist())


def test_pieces_refuse_what_they_cannot_be(stores):
    store = simplexdb.open(stores / "ht.sdb")
    with pytest.raises(ValueError, match="both"):
        store.extract("1%", piece=0)
    with pytest.raises(ValueError, match="piece 2 of --pieces 2"):
        store.extract("1%", piece=2, pieces=2)
    with pytest.raises(ValueError, match="only depth-first"):
        store.extract("1%", piece=0, pieces=2, algorithm="priority")


def test_threads_get_what_one_thread_gets(stores):
    store = simplexdb.open(stores / "ht.sdb", cache_mb=1)
    want = {e: store.extract(e).codes for e in ("1%", "4%", "10%")}
    got = {}

    def work(e):
        for _ in range(3):
            got.setdefault(e, []).append(store.extract(e).codes)

    threads = [threading.Thread(target=work, args=(e,)) for e in want]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for e, runs in got.items():
        for codes in runs:
            np.testing.assert_array_equal(codes, want[e])


def test_bad_arguments_raise_with_the_message(stores):
    store = simplexdb.open(stores / "ht.sdb")
    with pytest.raises(ValueError, match="expected a number >= 0"):
        store.extract("lots")
    with pytest.raises(ValueError, match="expected a number >= 0"):
        store.extract(-1)
    with pytest.raises(ValueError, match="algorithm"):
        store.extract("1%", algorithm="sideways")
    with pytest.raises(ValueError, match="box"):
        store.extract("1%", box=(1, 2, 3))
    with pytest.raises(ValueError, match="time"):
        store.extract("1%", time=2)  # an HT has no time
    with pytest.raises(OSError, match="nowhere.sdb"):
        simplexdb.open(stores / "nowhere.sdb")


@pytest.mark.parametrize("name,in_memory", [("ht.sdb", False), ("ht.sdb", True), ("ht.lmdb", False)])
@pytest.mark.parametrize("keep", [0.5, 0.0])
@pytest.mark.parametrize("operation", ["extract", "export", "field_at"])
def test_a_store_truncated_while_open_raises_and_the_interpreter_lives(stores, tmp_path, name, in_memory, keep,
                                                                     operation):
    # Issue 46: a long-lived reader (a notebook, a ParaView session) whose
    # store is cut short under it gets an OSError, never a SIGBUS.
    import os
    import shutil
    path = tmp_path / name
    shutil.copyfile(stores / name, path)
    store = simplexdb.open(path, cache_mb=1, in_memory=in_memory)
    run_it = {
        "extract": lambda: store.extract("2%"),
        "export": lambda: store.export(),
        "field_at": lambda: store.field_at(np.array([[1.0, 2.0, 3.0]]), units="grid"),
    }[operation]
    run_it()
    os.truncate(path, int(os.path.getsize(path) * keep))
    with pytest.raises(OSError, match="changed after it was opened.*open it again"):
        run_it()


def test_a_store_written_in_place_while_open_raises(stores, tmp_path):
    import os
    import shutil
    import time
    for name in ["ht.sdb", "ht.lmdb"]:
        path = tmp_path / name
        shutil.copyfile(stores / name, path)
        store = simplexdb.open(path)
        store.extract("2%")
        time.sleep(0.02)  # the file system's clock is coarse
        with builtins.open(path, "r+b") as f:
            f.seek(os.path.getsize(path) // 2 & ~4095)
            f.write(b"\x5a" * 8192)
        with pytest.raises(OSError, match=str(path)):
            store.extract("1%")


def test_a_damaged_store_raises(stores):
    damaged = stores / "damaged.sdb"
    data = bytearray((stores / "ht.sdb").read_bytes())
    for i in range(4096, len(data), 97):
        data[i] ^= 0x5A
    damaged.write_bytes(bytes(data))
    with pytest.raises(OSError):
        simplexdb.open(damaged).extract(0)
    truncated = stores / "truncated.sdb"
    truncated.write_bytes(bytes(data[:100]))
    with pytest.raises((OSError, ValueError)):
        simplexdb.open(truncated)
