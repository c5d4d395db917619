"""examples/python_thresholds.py runs on the shared tooth volume and writes
the PNGs it says it wrote (run by ctest with the package on PYTHONPATH and
SIMPLEXDB_CLI set, as the other Python tests; the example needs no CLI)."""
import os
import pathlib
import subprocess
import sys

import pytest

REPOSITORY = pathlib.Path(__file__).resolve().parents[2]
SCRIPT = REPOSITORY / "examples" / "python_thresholds.py"
TOOTH = REPOSITORY.parent / "shared" / "data" / "tooth" / "tooth_103x94x161_uint8.raw"


@pytest.mark.skipif(not TOOTH.is_file(), reason=f"{TOOTH} is absent: the example needs ../shared/data beside "
                                                  "the repository")
def test_example_writes_its_pngs(tmp_path):
    done = subprocess.run([sys.executable, str(SCRIPT), str(tmp_path / "out")], capture_output=True, text=True,
                          env=dict(os.environ, MPLBACKEND="Agg"), timeout=300)
    assert done.returncode == 0, done.stderr
    import matplotlib.image
    for name, (height, width) in (("mesh_sizes.png", (400, 600)), ("slice.png", (550, 1200))):
        png = tmp_path / "out" / name
        assert f"wrote {png}" in done.stdout
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        image = matplotlib.image.imread(png)
        assert image.shape[:2] == (height, width) and image.shape[2] in (3, 4)
        # Drawn, not blank: many distinct colours.
        assert len({tuple(p) for p in image.reshape(-1, image.shape[2])[::7]}) > 20
    # One line per threshold, its mesh's size.
    assert done.stdout.count("tetrahedra,") == 2
