"""simplexdb.import_volume, Store.export, Store.field_at and simplexdb.codes
against the command line they must agree with (`simplexdb import`,
`export`, `codes`) and against numpy's own indexing (brute-force truth).

Arrays are small and seeded, so the suite stays fast and every failure
repeats.
"""
import json

import numpy as np
import pytest

import simplexdb
from cli import run

DTYPES = ["uint8", "int8", "uint16", "int16", "float32", "float64"]
SHAPES = {"ht": (5, 6, 7), "hp": (3, 4, 5, 6)}  # C order: (Z, Y, X), (T, Z, Y, X)


def voxels(dtype, shape, seed=3):
    rng = np.random.default_rng(seed)
    t = np.dtype(dtype)
    if t.kind == "f":
        return rng.normal(10, 50, size=shape).astype(t)
    info = np.iinfo(t)
    return rng.integers(info.min, info.max, size=shape, endpoint=True, dtype=t)


def dims_text(a):
    return ",".join(str(n) for n in reversed(a.shape))  # x first


def cli_import(tmp_path, a, name, *options):
    """The store `simplexdb import --threads 1` builds from `a` written as a
    raw file; returns (store path, the raw path the store names as its
    source). One thread: with more, the dense store's bricks are laid out in
    the order the threads finish them, and byte comparisons would be luck."""
    raw = tmp_path / f"{name}.raw"
    a.tofile(raw)
    out = tmp_path / f"{name}.cli"
    run("import", raw, "--dims", dims_text(a), "--type", a.dtype.name, "--threads", 1, "-q", "-o", out,
        *options)
    return out, raw


@pytest.mark.parametrize("hierarchy", ["ht", "hp"])
@pytest.mark.parametrize("dtype", DTYPES)
def test_array_builds_the_store_a_raw_file_builds(tmp_path, hierarchy, dtype):
    a = voxels(dtype, SHAPES[hierarchy])
    cli, raw = cli_import(tmp_path, a, "v")
    expected = cli.read_bytes()
    source = f"raw file {raw}"  # what the CLI records; the only header field that could differ
    for name, array in [("c", a), ("fortran", np.asfortranarray(a.T))]:
        store = simplexdb.import_volume(array, tmp_path / f"{name}.sdb", progress=False, source=source,
                                        threads=1)
        assert store.info["hierarchy"] == hierarchy
        assert store.dims == tuple(reversed(a.shape))
        assert (tmp_path / f"{name}.sdb").read_bytes() == expected, name
    # The raw file itself, through Python, gives the same store too.
    simplexdb.import_volume(raw, tmp_path / "path.sdb", dims=a.shape[::-1], dtype=a.dtype, progress=False,
                            threads=1)
    assert (tmp_path / "path.sdb").read_bytes() == expected


@pytest.mark.parametrize("quantization, compression", [("u8", "none"), ("f32", "zstd")])
def test_options_map_to_the_cli_options(tmp_path, quantization, compression):
    a = voxels("int16", SHAPES["ht"])
    cli, raw = cli_import(tmp_path, a, "v", "--quantization", quantization, "--compression", compression)
    simplexdb.import_volume(a, tmp_path / "py.sdb", quantization=quantization, compression=compression,
                            progress=False, source=f"raw file {raw}", threads=1)
    assert (tmp_path / "py.sdb").read_bytes() == cli.read_bytes()


def test_big_endian_and_strided_arrays(tmp_path):
    a = voxels("uint16", SHAPES["ht"])
    cli, raw = cli_import(tmp_path, a, "v")
    source = f"raw file {raw}"
    simplexdb.import_volume(a.astype(">u2"), tmp_path / "be.sdb", progress=False, source=source, threads=1)
    assert (tmp_path / "be.sdb").read_bytes() == cli.read_bytes()
    # A view with steps is neither C nor Fortran order: copied in C order.
    wide = np.zeros((5, 12, 7), dtype=np.uint16)
    wide[:, ::2, :] = a
    simplexdb.import_volume(wide[:, ::2, :], tmp_path / "strided.sdb", progress=False, source=source,
                            threads=1)
    assert (tmp_path / "strided.sdb").read_bytes() == cli.read_bytes()


def test_views_keep_their_orientation(tmp_path):
    # Issue 46: a broadcast view (zero strides) imported transposed. Every
    # view reads back as the array it is, axis for axis.
    a = voxels("uint8", (5, 6, 7))
    views = {
        "broadcast x": np.broadcast_to(np.arange(7, dtype=np.uint8), (5, 6, 7)),
        "broadcast z": np.broadcast_to(np.arange(5, dtype=np.uint8)[:, None, None], (5, 6, 7)),
        "flipped": a[::-1, :, ::-1],
        "fortran strided": np.asfortranarray(voxels("uint8", (7, 12, 5)))[:, ::2, :],
        "transposed view": np.ascontiguousarray(a.transpose(2, 1, 0)).transpose(2, 1, 0)[:, :, :],
    }
    for name, view in views.items():
        store = simplexdb.import_volume(view, tmp_path / (name.replace(" ", "_") + ".sdb"), progress=False)
        exported = store.export()
        c_order = not view.flags.f_contiguous and not name.startswith("fortran")
        expected = view if c_order else np.asarray(view).T
        assert exported.shape == expected.shape, name
        np.testing.assert_array_equal(exported, expected, err_msg=name)


@pytest.mark.parametrize("hierarchy", ["ht", "hp"])
def test_sparse_import_matches_the_cli(tmp_path, hierarchy):
    a = voxels("uint8", SHAPES[hierarchy])
    cli, _ = cli_import(tmp_path, a, "v", "--sparse")
    py = simplexdb.import_volume(np.asfortranarray(a.T), tmp_path / "py.lmdb", sparse=True, progress=False)
    assert py.info["kind"] == f"{hierarchy}-sparse"
    np.testing.assert_array_equal(py.export(), a)
    np.testing.assert_array_equal(simplexdb.open(cli).export(), a)
    threshold = "3%" if hierarchy == "ht" else "10%"
    py_mesh, cli_mesh = py.extract(threshold, mesh=False), simplexdb.open(cli).extract(threshold, mesh=False)
    np.testing.assert_array_equal(py_mesh.codes, cli_mesh.codes)


def test_spacing_and_origin_are_kept(tmp_path):
    a = voxels("float32", SHAPES["hp"])
    store = simplexdb.import_volume(a, tmp_path / "p.sdb", spacing=(0.5, 2, 1.25, 0.1),
                                    origin=(-3, 4, 5.5, 100), progress=False)
    assert store.spacing == (0.5, 2.0, 1.25, 0.1)
    assert store.origin == (-3.0, 4.0, 5.5, 100.0)
    info = json.loads(run("info", tmp_path / "p.sdb", "--json"))
    assert info["spacing"] == [0.5, 2.0, 1.25, 0.1] and info["origin"] == [-3.0, 4.0, 5.5, 100.0]
    assert info["source"] == "numpy array (float32, 6x5x4x3)"
    # A NRRD's own spacing is kept, and replaced when spacing= is given.
    raw = tmp_path / "v.raw"
    voxels("uint8", SHAPES["ht"]).tofile(raw)
    nhdr = tmp_path / "v.nhdr"
    nhdr.write_text("NRRD0004\ntype: uint8\ndimension: 3\nsizes: 7 6 5\nspacings: 0.5 2 1.5\n"
                    "encoding: raw\ndata file: v.raw\n\n")
    assert simplexdb.import_volume(nhdr, tmp_path / "n.sdb", progress=False).spacing == (0.5, 2.0, 1.5)
    assert simplexdb.import_volume(nhdr, tmp_path / "m.sdb", spacing=[1, 1, 3],
                                   progress=False).spacing == (1.0, 1.0, 3.0)


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("hierarchy", ["ht", "hp"])
def test_export_gives_the_array_back(tmp_path, dtype, hierarchy):
    a = voxels(dtype, SHAPES[hierarchy])
    store = simplexdb.import_volume(a, tmp_path / "a.sdb", progress=False)
    back = store.export()
    assert back.dtype == a.dtype and back.flags.c_contiguous
    np.testing.assert_array_equal(back, a)
    f = simplexdb.import_volume(np.asfortranarray(a.T), tmp_path / "f.sdb", progress=False)
    np.testing.assert_array_equal(f.export(), a)  # the same memory: the same (Z, Y, X) array


def test_export_of_a_lossy_integer_store_stays_in_range(tmp_path):
    # Values pinned at 0 and 255 with noise: a lossy sparse store rebuilds
    # some beyond the type's range (-1), which must clamp, not wrap to 255.
    x = np.arange(24)
    base = np.where(x < 8, 0, np.where(x < 16, 128, 255))
    noise = np.random.default_rng(12345).integers(-7, 9, size=(18, 20, 24))
    a = np.clip(base + noise, 0, 255).astype(np.uint8)
    a.tofile(tmp_path / "v.raw")
    for tolerance in (4, 20):
        store = tmp_path / f"s{tolerance}.lmdb"
        run("import", tmp_path / "v.raw", "--dims", "24,20,18", "--type", "uint8", "--sparse", "--tolerance",
            tolerance, "-o", store, "-q")
        got = simplexdb.open(store).export()
        assert got.dtype == np.uint8
        assert np.abs(got.astype(np.int64) - a).max() <= tolerance + 0.5


def test_export_roi_and_step_match_numpy_and_the_cli(tmp_path):
    a = voxels("int16", (9, 10, 11))
    store = simplexdb.import_volume(a, tmp_path / "a.sdb", progress=False)
    for roi, step in [((1, 2, 3, 9, 8, 7), 1), ((0, 0, 0, 10, 9, 8), 2), ((2, 1, 1, 10, 9, 8), 3)]:
        x0, y0, z0, x1, y1, z1 = roi
        got = store.export(roi=roi, step=step)
        np.testing.assert_array_equal(got, a[z0:z1 + 1:step, y0:y1 + 1:step, x0:x1 + 1:step])
        out = tmp_path / "part.raw"
        run("export", tmp_path / "a.sdb", "--roi", ",".join(map(str, roi)), "--step", step, "-o", out,
            "--force")
        np.testing.assert_array_equal(np.fromfile(out, dtype=np.int16).reshape(got.shape), got)


def test_field_at_grid_points_is_the_array(tmp_path):
    a = voxels("float32", SHAPES["ht"])
    origin = (10.0, -4.0, 0.25)
    # y flipped in the last: grid y runs towards smaller physical y.
    for name, sparse, spacing in [("d.sdb", False, (0.5, 2.0, 1.5)), ("s.lmdb", True, (0.5, 2.0, 1.5)),
                                  ("f.sdb", False, (0.5, -2.0, 1.5))]:
        store = simplexdb.import_volume(a, tmp_path / name, spacing=spacing, origin=origin, sparse=sparse,
                                        progress=False)
        z, y, x = np.meshgrid(*[np.arange(n) for n in a.shape], indexing="ij")
        grid = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1).astype(np.float64)
        truth = a[z.ravel(), y.ravel(), x.ravel()].astype(np.float64)
        np.testing.assert_array_equal(store.field_at(grid, units="grid"), truth)
        physical = np.asarray(origin) + grid * np.asarray(spacing)
        np.testing.assert_array_equal(store.field_at(physical), truth)
    hp = voxels("int16", SHAPES["hp"])
    store = simplexdb.import_volume(hp, tmp_path / "hp.sdb", progress=False)
    rng = np.random.default_rng(5)
    idx = np.stack([rng.integers(0, n, 50) for n in hp.shape], axis=1)  # t, z, y, x
    np.testing.assert_array_equal(store.field_at(idx[:, ::-1], units="grid"), hp[tuple(idx.T)])


@pytest.mark.parametrize("hierarchy", ["ht", "hp"])
def test_field_at_interpolates_within_the_finest_simplex(tmp_path, hierarchy):
    shape = SHAPES[hierarchy]
    d = len(shape)
    rng = np.random.default_rng(11)
    # A linear field is reproduced exactly by any piecewise-linear interpolant.
    coords = np.meshgrid(*[np.arange(n, dtype=np.float64) for n in shape], indexing="ij")  # t?, z, y, x
    weights = [2.0, -3.0, 0.5, 1.25][:d]
    linear = (sum(w * c for w, c in zip(weights, coords)) + 7).astype(np.float64)
    store = simplexdb.import_volume(linear, tmp_path / "lin.sdb", progress=False)
    p = rng.uniform(0, 1, size=(200, d)) * (np.array(shape[::-1]) - 1)  # x first
    truth = sum(w * p[:, d - 1 - i] for i, w in enumerate(weights)) + 7
    np.testing.assert_allclose(store.field_at(p, units="grid"), truth, rtol=0, atol=1e-9)
    # Any field: inside a grid cell the value lies between the cell's corner
    # values; along a grid edge it is the mean of the edge's ends at its middle.
    a = voxels("float64", shape)
    store = simplexdb.import_volume(a, tmp_path / "any.sdb", progress=False)
    values = store.field_at(p, units="grid")
    lo = np.floor(p).astype(int)
    for row, v in zip(lo, values):
        cell = a[tuple(slice(i, i + 2) for i in row[::-1])]
        assert cell.min() - 1e-9 <= v <= cell.max() + 1e-9
    start = np.stack([rng.integers(0, n - 1 if i == 0 else n, 40) for i, n in enumerate(shape[::-1])],
                     axis=1)  # x first; x < nx - 1
    mid = start.astype(np.float64)
    mid[:, 0] += 0.5
    ends = a[tuple(start[:, ::-1].T)], a[tuple((start + np.eye(d, dtype=int)[0])[:, ::-1].T)]
    np.testing.assert_allclose(store.field_at(mid, units="grid"), (ends[0] + ends[1]) / 2, rtol=1e-12)


def test_codes_are_the_cli_objects():
    cases = {
        "ht": ["0:", "2:10011", "5:0110101"],
        "hp": ["0:", "7:10100110101100100011"],
        "tri-icosahedron": ["2:010001010001"],
    }
    for hierarchy, codes in cases.items():
        printed = run("codes", "--hierarchy", hierarchy, stdin="\n".join(codes) + "\n").splitlines()
        assert simplexdb.codes(hierarchy, codes) == [json.loads(line) for line in printed]
        assert simplexdb.codes(hierarchy, codes[0]) == json.loads(printed[0])
        assert simplexdb.codes(hierarchy.upper(), codes[:1]) == [json.loads(printed[0])]
    with pytest.raises(ValueError, match="not a location code"):
        simplexdb.codes("ht", ["0:", "banana"])
    with pytest.raises(ValueError, match="expected ht, hp, tri-icosahedron"):
        simplexdb.codes("quad", ["0:"])


def test_progress_goes_to_a_terminal_stderr_only(tmp_path, capfd):
    # Issue 40: the progress line goes through sys.stderr (redirect_stderr
    # takes it), with its escape codes only when that is a terminal, as the
    # command's; a file, a pipe or a notebook's stream gets nothing.
    import contextlib
    import io

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    terminal, plain = Terminal(), io.StringIO()
    with contextlib.redirect_stderr(terminal):
        simplexdb.import_volume(voxels("uint8", SHAPES["ht"]), tmp_path / "a.sdb")
    assert str(tmp_path / "a.sdb") + ": " in terminal.getvalue()
    assert terminal.getvalue().endswith("\r\033[K")  # the line cleared at the end
    with contextlib.redirect_stderr(plain):
        simplexdb.import_volume(voxels("uint8", SHAPES["ht"]), tmp_path / "b.sdb")
    assert plain.getvalue() == ""
    simplexdb.import_volume(voxels("uint8", SHAPES["ht"]), tmp_path / "c.sdb")  # pytest's stderr: no terminal
    simplexdb.import_volume(voxels("uint8", SHAPES["ht"]), tmp_path / "d.sdb", progress=False)
    assert capfd.readouterr().err == ""


def test_bad_arguments_raise_with_the_reason(tmp_path):
    a = voxels("uint8", SHAPES["ht"])
    out = tmp_path / "x.sdb"
    with pytest.raises(ValueError, match="dtype int32 is not a voxel type.*float32, float64, int16"):
        simplexdb.import_volume(a.astype(np.int32), out)
    with pytest.raises(ValueError, match=r"expected 3 axes .* got shape \(6, 7\)"):
        simplexdb.import_volume(a[0], out)
    with pytest.raises(ValueError, match="unknown quantization 'u4': expected u16, u8 or f32"):
        simplexdb.import_volume(a, out, quantization="u4")
    with pytest.raises(ValueError, match="unknown compression 'lz4': expected none or zstd"):
        simplexdb.import_volume(a, out, compression="lz4")
    with pytest.raises(ValueError, match="hierarchy hp needs a 4D volume"):
        simplexdb.import_volume(a, out, hierarchy="hp")
    with pytest.raises(ValueError, match="spacing: 2 numbers for a 3D volume"):
        simplexdb.import_volume(a, out, spacing=(1, 2))
    with pytest.raises(ValueError, match="spacing: 0 on axis 1 is not a finite non-zero number"):
        simplexdb.import_volume(a, out, spacing=(1, 0, 2))
    with pytest.raises(ValueError, match=r"spacing: -1 on axis 3 is not a finite number > 0 \(time"):
        simplexdb.import_volume(voxels("uint8", SHAPES["hp"]), out, spacing=(1, 1, 1, -1))
    assert not out.exists()
    with pytest.raises(OSError, match="missing.nrrd"):
        simplexdb.import_volume(tmp_path / "missing.nrrd", out)
    with pytest.raises(OSError, match="missing.raw"):
        simplexdb.import_volume(tmp_path / "missing.raw", out, dims=(7, 6, 5), dtype="uint8")
    store = simplexdb.import_volume(a, out, progress=False)
    with pytest.raises(ValueError, match="step: expected a whole number >= 1, not -1"):
        store.export(step=-1)
    with pytest.raises(ValueError, match=r"axis 2 range 0..5 is not within 0..4"):
        store.export(roi=(0, 0, 0, 6, 5, 5))
    with pytest.raises(ValueError, match="roi: expected 6 grid indices"):
        store.export(roi=(0, 0, 0, 1))
    with pytest.raises(ValueError, match=r"point \(7\.0, 0\.0, 0\.0\) is outside the grid \(0..6, 0..5, 0..4"):
        store.field_at([[1, 1, 1], [7, 0, 0]])
    with pytest.raises(ValueError, match=r"point \(0, 0, -0\.5\) is outside the grid \(0..6, 0..5, 0..4, grid"):
        store.field_at([[0, 0, -0.5]], units="grid")
    with pytest.raises(ValueError, match="threads: expected a count >= 0"):
        simplexdb.import_volume(a, tmp_path / "y.sdb", threads=-1)
    with pytest.raises(ValueError, match=r"points: expected an N x 3 array"):
        store.field_at([[1, 2]])
