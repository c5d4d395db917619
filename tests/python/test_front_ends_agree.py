"""The command line and the Python package run the same operations (ops/):
for a dense and a sparse store, HT and HP, the same mesh (the .vtu's bytes
and the leaf codes), the same export (the files' bytes, and the values
against the voxels put in) and the same conversion (the new store's bytes).

Stores are built with one thread (a dense store's bricks are laid out in
the order the threads finish them) and compared file by file, each front
end writing under the same name in its own folder.
"""
import numpy as np
import pytest

import simplexdb
from cli import run

TOLERANCE = 6  # the sparse stores' (field units): lossy, so rebuilt values are rounded


def field(shape, seed):
    """A smooth uint8 field with noise, C order (T?, Z, Y, X)."""
    rng = np.random.default_rng(seed)
    axes = np.meshgrid(*[np.linspace(0, 3, n) for n in shape], indexing="ij")
    smooth = 128 + 90 * np.sin(sum((i + 1) * a for i, a in enumerate(axes)))
    return np.clip(smooth + rng.normal(0, 6, size=shape), 0, 255).astype(np.uint8)


VOLUMES = {"ht": field((19, 12, 21), 1), "hp": field((6, 7, 8, 9), 2)}
KINDS = ["dense", "sparse"]


@pytest.fixture(scope="module")
def stores(tmp_path_factory):
    d = tmp_path_factory.mktemp("agree")
    for hierarchy, a in VOLUMES.items():
        raw = d / f"{hierarchy}.raw"
        a.tofile(raw)
        dims = ",".join(str(n) for n in reversed(a.shape))
        common = ["import", raw, "--dims", dims, "--type", "uint8", "--threads", 1, "-q"]
        run(*common, "--spacing", ",".join(["0.5", "-2", "1.5", "0.25"][:a.ndim]), "-o", d / f"{hierarchy}.dense")
        run(*common, "--sparse", "--tolerance", TOLERANCE, "-o", d / f"{hierarchy}.sparse")
    return d


def folders(tmp_path):
    cli, py = tmp_path / "cli", tmp_path / "py"
    cli.mkdir()
    py.mkdir()
    return cli, py


def check_values(hierarchy, kind, values):
    """Against the voxels put in: exact for the dense store, within the
    tolerance (rounded to uint8) for the lossy sparse one."""
    a = VOLUMES[hierarchy]
    assert values.shape == a.shape and values.dtype == np.uint8
    if kind == "dense":
        np.testing.assert_array_equal(values, a)
    else:
        assert np.abs(values.astype(int) - a).max() <= TOLERANCE + 0.5


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("hierarchy", ["ht", "hp"])
def test_the_same_mesh(stores, tmp_path, hierarchy, kind):
    store = stores / f"{hierarchy}.{kind}"
    cli, py = folders(tmp_path)
    criteria = ["--error", "4%", "--iso", "120"] + (["--time", "2.5"] if hierarchy == "hp" else [])
    run("extract", store, *criteria, "-o", cli / "m.vtu")
    codes = run("extract", store, *criteria, "--format", "codes").split()
    mesh = simplexdb.open(store).extract("4%", iso=120, time=2.5 if hierarchy == "hp" else None)
    mesh.save(py / "m.vtu")
    assert mesh.code_strings() == codes
    assert len(codes) > (6 if hierarchy == "ht" else 24)  # refined past the roots
    assert (py / "m.vtu").read_bytes() == (cli / "m.vtu").read_bytes()


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("hierarchy", ["ht", "hp"])
def test_the_same_export(stores, tmp_path, hierarchy, kind):
    store_path = stores / f"{hierarchy}.{kind}"
    store = simplexdb.open(store_path)
    cli, py = folders(tmp_path)
    # The whole field: one image (HT) or a series of time steps (HP).
    name = "f.nrrd" if hierarchy == "ht" else "f.pvd"
    run("export", store_path, "-o", cli / name)
    store.export(out=py / name)
    assert sorted(p.name for p in py.iterdir()) == sorted(p.name for p in cli.iterdir())
    for f in cli.iterdir():
        assert (py / f.name).read_bytes() == f.read_bytes(), f.name
    # A box, every second point, as raw + .nhdr; HP: one time step.
    roi = "1,2,1,9,10,5" if hierarchy == "ht" else "1,2,1,7,6,5"
    time = [] if hierarchy == "ht" else ["--time", "3"]
    run("export", store_path, "--roi", roi, "--step", 2, *time, "-o", cli / "box.raw")
    store.export(roi=[int(x) for x in roi.split(",")], step=2, time=3 if time else None, out=py / "box.raw")
    for f in ("box.raw", "box.nhdr"):
        assert (py / f).read_bytes() == (cli / f).read_bytes(), f
    part = store.export(roi=[int(x) for x in roi.split(",")], step=2, time=3 if time else None)
    if kind == "dense":
        part = part[..., ::-1, :]  # its y spacing is negative: the files hold y forwards
    np.testing.assert_array_equal(np.fromfile(cli / "box.raw", np.uint8).reshape(part.shape), part)
    check_values(hierarchy, kind, store.export())


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("hierarchy", ["ht", "hp"])
def test_the_same_conversion(stores, tmp_path, hierarchy, kind):
    store = stores / f"{hierarchy}.{kind}"
    cli, py = folders(tmp_path)
    to = "sparse" if kind == "dense" else "dense"
    options = ["--tolerance", "1%"] if to == "sparse" else []
    run("convert", store, "--to", to, *options, "--threads", 1, "-q", "-o", cli / "c.store")
    converted = simplexdb.convert(store, py / "c.store", to=to, tolerance="1%" if options else 0, threads=1,
                                  progress=False)
    assert (py / "c.store").read_bytes() == (cli / "c.store").read_bytes()
    assert converted.info["kind"] == f"{hierarchy}-{to}"
    back = converted.export()
    if to == "dense":
        # The sparse store's rebuilt values, in its type, are the new store's.
        np.testing.assert_array_equal(back, simplexdb.open(store).export())
        check_values(hierarchy, kind, back)
    else:
        lo, hi = converted.field_range
        assert np.abs(back.astype(int) - VOLUMES[hierarchy]).max() <= 0.01 * (hi - lo) + 0.5


def test_the_same_incremental_refinement(stores, tmp_path):
    """--algorithm incremental --from CODES and extract(previous=mesh): the
    previous mesh as leaf codes either way, the same mesh from it."""
    store = stores / "ht.dense"
    coarse = simplexdb.open(store).extract("10%", mesh=False)
    (tmp_path / "coarse.codes").write_text(run("extract", store, "--error", "10%", "--format", "codes"))
    assert coarse.code_strings() == (tmp_path / "coarse.codes").read_text().split()
    codes = run("extract", store, "--error", "2%", "--algorithm", "incremental", "--from", tmp_path / "coarse.codes",
                "--format", "codes").split()
    fine = simplexdb.open(store).extract("2%", algorithm="incremental", previous=coarse, mesh=False)
    assert fine.code_strings() == codes
    assert fine.stats["algorithm"] == "incremental" and len(codes) > len(coarse.codes)


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("hierarchy", ["ht", "hp"])
def test_the_same_isosurface(stores, tmp_path, hierarchy, kind):
    """`simplexdb isosurface` and Store.isosurface: the same .vtp and .ply
    bytes, and the arrays the files hold."""
    store = stores / f"{hierarchy}.{kind}"
    cli, py = folders(tmp_path)
    extra = ["--time", "2.5"] if hierarchy == "hp" else []
    s = simplexdb.open(store).isosurface(140, error="3%", time=2.5 if hierarchy == "hp" else None)
    assert len(s.triangles) > 0 and s.normals.shape == s.points.shape and len(s.error) == len(s.triangles)
    for ext in ("vtp", "ply"):
        run("isosurface", store, "--iso", "140", "--error", "3%", *extra, "-q", "-o", cli / f"s.{ext}")
        s.save(py / f"s.{ext}")
        assert (cli / f"s.{ext}").read_bytes() == (py / f"s.{ext}").read_bytes(), ext
    with pytest.raises(ValueError, match=".vtp"):
        s.save(py / "s.stl")
