"""Issue 46: one set of checks for every front end. The same bad requests
through `simplexdb` and through the Python package are refused by the same
library check with the same words (the CLI exits 2 and prints
"simplexdb: <message>"; Python raises ValueError with <message>, naming its
arguments where the command names its options: PYTHON_NAMES), and nothing
is written. Also the Python-only refusals: arguments of the wrong type
raise ValueError naming the argument, never pybind's signature dump.
"""
import re
import subprocess

import numpy as np
import pytest

import simplexdb
from cli import CLI, run


# What Python calls the options the library's messages name (issue 40: a
# Python user is told about time=, not --time).
PYTHON_NAMES = {"--time-limit": "time_limit", "--time": "time", "--error": "error", "--box": "box", "--iso": "iso",
                "--units": "units", "--algorithm": "algorithm", "--budget": "budget", "--spacing": "spacing",
                "--slices": "slices"}


def in_python_words(message):
    return re.sub(r"(?<![\w-])--[a-z-]+(?![\w-])", lambda m: PYTHON_NAMES.get(m.group(0), m.group(0)), message)


def refused(*args):
    """Runs `simplexdb ARGS`, which must fail: (exit code, the message
    without the tool's prefix)."""
    done = subprocess.run([CLI, *map(str, args)], capture_output=True, text=True)
    assert done.returncode != 0, f"{args} was accepted"
    lines = [line for line in done.stderr.splitlines() if line.startswith("simplexdb: ")]
    if lines:
        return done.returncode, lines[-1][len("simplexdb: "):]
    # The command line's own parser (CLI11): "--iso: ...", then a hint.
    assert done.stderr.strip(), args
    return done.returncode, done.stderr.splitlines()[0]


@pytest.fixture(scope="module")
def stores(tmp_path_factory):
    d = tmp_path_factory.mktemp("refusals")
    run("generate", "--field", "sines", "--dims", "9,8,7,2", "--type", "uint8", "-q", "-o", d / "hp.nrrd")
    run("import", d / "hp.nrrd", "--spacing", "1,1,1,500", "-o", d / "hp.sdb", "-q")
    run("generate", "--field", "sines", "--dims", "9,8,7", "--type", "uint8", "-q", "-o", d / "ht.nrrd")
    run("import", d / "ht.nrrd", "--spacing=-1,1,1", "--origin", "8,0,0", "-o", d / "ht.sdb", "-q")
    return d


# (store, CLI arguments after the store, the same request in Python)
EXTRACT_CASES = [
    ("hp.sdb", ["--error", "5%", "--time", "2"], dict(error="5%", time=2)),
    ("hp.sdb", ["--error", "5%", "--time", "-1"], dict(error="5%", time=-1)),
    ("hp.sdb", ["--error", "5%", "--time", "1e9"], dict(error="5%", time=1e9)),
    ("hp.sdb", ["--error", "5%", "--time", "1000", "--units", "physical"], dict(error="5%", time=1000,
                                                                               units="physical")),
    ("ht.sdb", ["--error", "5%", "--budget", "5"], dict(error="5%", budget=5)),
    ("ht.sdb", ["--error", "5%", "--iso", "1e6"], dict(error="5%", iso=1e6)),
    ("ht.sdb", ["--error", "5%", "--box", "100,100,100,200,200,200"], dict(error="5%", box=(100, 100, 100,
                                                                                           200, 200, 200))),
    # A physical box on the flipped axis x, given high to low: in the units given.
    ("ht.sdb", ["--error", "5%", "--units", "physical", "--box", "6,0,0,2,3,3"],
     dict(error="5%", units="physical", box=(6, 0, 0, 2, 3, 3))),
    ("ht.sdb", ["--error", "lots"], dict(error="lots")),
    ("ht.sdb", ["--error", "5%", "--algorithm", "sideways"], dict(error="5%", algorithm="sideways")),
]


@pytest.mark.parametrize("store,cli_args,py_kwargs", EXTRACT_CASES)
def test_extract_refuses_alike(stores, tmp_path, store, cli_args, py_kwargs):
    out = tmp_path / "m.vtu"
    code, message = refused("extract", stores / store, *cli_args, "-o", out)
    assert code == 2, message
    assert not out.exists()
    with pytest.raises(ValueError) as e:
        simplexdb.open(stores / store).extract(**py_kwargs)
    assert str(e.value) == in_python_words(message)
    assert "--" not in str(e.value)


def test_slices_outside_the_store_are_refused(stores, tmp_path):
    for slices, units in [("0,1,5,-3", "grid"), ("9000", "physical")]:
        out = tmp_path / "z.pvd"
        code, message = refused("extract", stores / "hp.sdb", "--error", "20%", "--slices", slices,
                                "--units", units, "-o", out)
        assert code == 2
        assert "outside the store's times" in message, message
        assert not list(tmp_path.iterdir())


def test_numbers_are_decimal(stores, tmp_path):
    for args in [["--error", "0x10"], ["--error", "5%", "--iso", "0x10"], ["--error", "5%", "--iso", "inf"]]:
        code, message = refused("extract", stores / "ht.sdb", *args, "-o", tmp_path / "m.vtu")
        assert code == 2
        assert "0x10" in message or "inf" in message, message
    code, message = refused("import", stores / "ht.nrrd", "--spacing", "0x10,1,1", "-o", tmp_path / "s.sdb")
    assert code == 2 and "decimal" in message, message


def test_a_spacing_whose_grid_overflows_is_refused(stores, tmp_path):
    out = tmp_path / "s.sdb"
    code, message = refused("import", stores / "ht.nrrd", "--spacing", "1e308,1,1", "-o", out)
    assert code == 2
    assert "grid point 8 of axis 0 would lie at inf" in message, message
    with pytest.raises(ValueError) as e:
        simplexdb.import_volume(stores / "ht.nrrd", tmp_path / "p.sdb", spacing=(1e308, 1, 1), progress=False)
    assert str(e.value) == in_python_words(message)
    assert not out.exists() and not (tmp_path / "p.sdb").exists()


@pytest.mark.parametrize("sparse", [False, True])
def test_a_range_beyond_float32_is_refused_before_writing(tmp_path, sparse):
    a = np.zeros((4, 5, 6), dtype=np.float32)
    a[0, 0, 0], a[1, 1, 1] = 3e38, -3e38
    raw = tmp_path / "r.raw"
    a.tofile(raw)
    out = tmp_path / "r.sdb"
    extra = ["--sparse"] if sparse else []
    code, message = refused("import", raw, "--dims", "6,5,4", "--type", "float32", *extra, "-o", out)
    assert code == 1, message
    assert "a range of 6e+38, beyond float32's" in message, message
    with pytest.raises(ValueError, match="beyond float32's"):
        simplexdb.import_volume(a, tmp_path / "p.sdb", sparse=sparse, progress=False)
    assert not out.exists() and not (tmp_path / "p.sdb").exists()


def test_arguments_of_the_wrong_type_name_the_argument(stores, tmp_path):
    store = simplexdb.open(stores / "ht.sdb")
    a = np.zeros((4, 5, 6), dtype=np.uint8)
    cases = [
        (lambda: simplexdb.import_volume(a, tmp_path / "x.sdb", source=5, progress=False), "source"),
        (lambda: simplexdb.import_volume(a, tmp_path / "x.sdb", threads="two", progress=False), "threads"),
        (lambda: store.extract("5%", budget=2**64, algorithm="priority"), "budget"),
        (lambda: store.extract("5%", algorithm=None), "algorithm"),
        (lambda: store.extract("5%").save("\0.vtu"), "NUL"),
        (lambda: store.extract("5%").save(3.5), "path"),
        (lambda: simplexdb.open(7), "path"),
    ]
    for call, word in cases:
        with pytest.raises(ValueError) as e:
            call()
        assert word in str(e.value), str(e.value)
        assert "incompatible function arguments" not in str(e.value)
    # bytes are a file name, as for open()
    store.extract("5%").save(bytes(tmp_path / "b.vtu"))
    assert (tmp_path / "b.vtu").exists()


def test_files_that_are_not_stores_and_names_the_system_refuses_are_os_errors(stores, tmp_path):
    (tmp_path / "notes.txt").write_text("not a store\n" * 100)
    with pytest.raises(OSError, match="notes.txt"):
        simplexdb.open(tmp_path / "notes.txt")
    long_name = tmp_path / ("n" * 300 + ".vtu")
    with pytest.raises(OSError):
        simplexdb.open(stores / "ht.sdb").extract("5%").save(long_name)
    code, message = refused("extract", stores / "ht.sdb", "--error", "5%", "-o", "")
    assert "the output path is empty" in message, message


def test_random_requests_get_the_same_answer_from_both_front_ends(stores, tmp_path):
    # A property: for requests drawn at random (a fixed seed) from good and
    # bad values, `simplexdb extract` and Store.extract either both accept
    # (the same number of simplices) or both refuse with the same message.
    import json
    import random
    rng = random.Random(46)
    errors = ["5%", "0", "2.5", "-1", "1e400", "x", "7%%", "50%"]
    times = [None, 0, 1, 0.5, 2, -0.25, 1e9]
    isos = [None, 10, 128, 1e6, -5]
    budgets = [None, 1, 100]
    algorithms = ["depth-first", "priority", "level-order", "saturated", "nope"]
    for i in range(40):
        store = rng.choice(["ht.sdb", "hp.sdb"])
        error, time, iso = rng.choice(errors), rng.choice(times), rng.choice(isos)
        budget, algorithm = rng.choice(budgets), rng.choice(algorithms)
        if store == "hp.sdb" and time is None:
            time = 0
        args, kwargs = ["--error", error], dict(error=error)
        for flag, name, value in [("--time", "time", time), ("--iso", "iso", iso), ("--budget", "budget", budget)]:
            if value is not None:
                args += [flag, str(value)]
                kwargs[name] = value
        args += ["--algorithm", algorithm]
        kwargs["algorithm"] = algorithm
        done = subprocess.run([CLI, "extract", str(stores / store), *args, "--format", "json", "-o",
                               str(tmp_path / f"{i}.json")], capture_output=True, text=True)
        try:
            mesh = simplexdb.open(stores / store).extract(**kwargs, mesh=False)
            py = ("ok", len(mesh.codes))
        except ValueError as e:
            py = ("refused", str(e))
        if done.returncode == 0:
            cli = ("ok", json.loads((tmp_path / f"{i}.json").read_text())["simplices"])
        else:
            lines = [line[len("simplexdb: "):] for line in done.stderr.splitlines() if line.startswith("simplexdb: ")]
            cli = ("refused", in_python_words(lines[-1] if lines else done.stderr.splitlines()[0]))
        assert py == cli, f"{store} {args}"
