#!/usr/bin/python3
"""The README's usage runs as written (issue 40): every ```sh and ```python
block of its sections "Your own volume" and "From Python", in order, in a
fresh folder beside which ../shared is the real one (the blocks name
../shared/data as a user in the repository root does), with the build's
`simplexdb` first on PATH and its Python package on PYTHONPATH. A block
that fails fails the test, naming the block and the line.

    readme_usage_test.py README SIMPLEXDB PYTHON_PACKAGE_DIR SHARED_DIR
"""
import os
import re
import subprocess
import sys
import tempfile

SECTIONS = ("## Your own volume", "## From Python")


def blocks(readme):
    """(section, language, code) for each fenced block of SECTIONS."""
    text = open(readme, encoding="utf-8").read()
    out = []
    for title in SECTIONS:
        start = text.index(title + "\n")
        end = text.find("\n## ", start + len(title))
        body = text[start:end if end >= 0 else len(text)]
        for lang, code in re.findall(r"```(sh|python)\n(.*?)```", body, re.S):
            out.append((title, lang, code))
    return out


def main():
    readme, tool, package, shared = sys.argv[1:5]
    if not os.path.isdir(os.path.join(shared, "data")):
        print("no shared data: skipped")
        return 77
    found = blocks(readme)
    assert any(l == "sh" for _, l, _ in found) and any(l == "python" for _, l, _ in found), found
    with tempfile.TemporaryDirectory() as tmp:
        os.symlink(os.path.abspath(shared), os.path.join(tmp, "shared"))
        work = os.path.join(tmp, "repository")
        os.mkdir(work)
        env = dict(os.environ, PATH=os.path.dirname(os.path.abspath(tool)) + os.pathsep + os.environ["PATH"],
                   PYTHONPATH=os.path.abspath(package))
        for i, (title, lang, code) in enumerate(found):
            command = ["bash", "-euo", "pipefail", "-c", code] if lang == "sh" else ["/usr/bin/python3", "-c", code]
            done = subprocess.run(command, cwd=work, env=env, capture_output=True, text=True)
            if done.returncode != 0:
                print(f"{title}, block {i + 1} ({lang}) failed with exit {done.returncode}:\n{code}\n"
                      f"stdout:\n{done.stdout}\nstderr:\n{done.stderr}")
                return 1
            print(f"{title}, block {i + 1} ({lang}): ok")
        for expected in ("tooth.sdb", "tooth.vtu", "tooth_zoom.vtu", "fmri.pvd", "tooth_py.vtu"):
            assert os.path.exists(os.path.join(work, expected)), expected
    return 0


if __name__ == "__main__":
    sys.exit(main())
