"""Store.info against `simplexdb info --json`, Mesh.save's formats (.vtu,
.pvd) read back by VTK, and Mesh.to_pyvista.

Run by ctest (label python) as test_simplexdb.py is: SIMPLEXDB_CLI names the
`simplexdb` tool of the same build and PYTHONPATH holds the built package.
"""
import json
import os
import subprocess
import sys
import types
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import simplexdb

CLI = os.environ.get("SIMPLEXDB_CLI", "simplexdb")


def run(*args):
    done = subprocess.run([CLI, *map(str, args)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return done.stdout


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
    # The same builder (query/store_info.h) and the same JSON text: equal
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
