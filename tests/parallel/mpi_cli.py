"""What the MPI tests of tests/parallel share: mpirun as root (the
environment OpenMPI needs in a container) and a runner of the command
with or without it."""
import os
import shutil
import subprocess
import sys

MPIRUN = shutil.which("mpirun")
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_btl_vader_single_copy_mechanism="none")


def require_mpirun():
    """Exits 77 (ctest's skip) when there is no mpirun."""
    if MPIRUN is None:
        print("no mpirun", file=sys.stderr)
        sys.exit(77)


def runner(cli):
    """run(args, mpi=N, expect=codes): `cli args`, under `mpirun -np N`
    when N is given; stops the test when the exit code is not expected."""
    def run(args, mpi=None, expect=(0,)):
        command = ([MPIRUN, "--oversubscribe", "-np", str(mpi)] if mpi else []) + [cli] + args
        p = subprocess.run(command, capture_output=True, text=True, env=ENV)
        if p.returncode not in expect:
            raise SystemExit(f"{' '.join(command)}: exit {p.returncode}, expected {expect}\n{p.stderr}")
        return p
    return run
