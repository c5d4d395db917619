"""The `simplexdb` command the Python tests compare the package with: the
tool of the same build (SIMPLEXDB_CLI, set by ctest), else `simplexdb` on
PATH."""
import os
import subprocess

CLI = os.environ.get("SIMPLEXDB_CLI", "simplexdb")


def run(*args, stdin=None):
    """Runs `simplexdb ARGS` (each converted with str) and returns its
    standard output; a non-zero exit fails the test with its stderr."""
    done = subprocess.run([CLI, *map(str, args)], capture_output=True, text=True, input=stdin)
    assert done.returncode == 0, done.stderr
    return done.stdout
