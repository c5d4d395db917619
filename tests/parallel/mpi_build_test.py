#!/usr/bin/python3
"""`mpirun -np N simplexdb import INPUT -o STORE` (issue 42): N ranks build
one store, each reading its own slabs of planes; the file must be the one
one process builds from the same input and options, byte for byte, and
`verify` must pass on it. HT and HP; NRRD, raw (big-endian, non-cubic)
and NIfTI input (a 3D float32 one with missing values, written here, and
the shared 4D fMRI), and a generated field (`--field`, no file);
N = 1..4. One process under a small --memory-mb
(many windows, spooled) must give the same bytes as one window. A rank
that fails (an infinity in its slabs, a full disk) stops every rank with
one message naming it and leaves neither a store nor a temporary; a rank
killed mid-build leaves no store, and the next run of the same output
leaves nothing but its store.

    mpi_build_test.py SIMPLEXDB_CLI WORKDIR SHARED_DATA

Exits 77 (skipped) when mpirun or numpy is missing.
"""
import json
import os
import shutil
import signal
import struct
import subprocess
import sys
import time

from mpi_cli import ENV, MPIRUN, require_mpirun, runner

try:
    import numpy as np
except ImportError as error:
    print(f"cannot import numpy: {error}", file=sys.stderr)
    sys.exit(77)

CLI, WORK, DATA = sys.argv[1], sys.argv[2], sys.argv[3]
require_mpirun()
run = runner(CLI)
failures = []


def write_nifti(path, values, spacing):
    """A NIfTI-1 single file (.nii) of float32 `values` (x fastest: the
    array is indexed [z, y, x]), no orientation: the header by the
    standard's layout, written here so the reader is tested against it."""
    nz, ny, nx = values.shape
    header = bytearray(352)
    struct.pack_into("<i", header, 0, 348)                      # sizeof_hdr
    struct.pack_into("<8h", header, 40, 3, nx, ny, nz, 1, 1, 1, 1)  # dim
    struct.pack_into("<hh", header, 70, 16, 32)                 # datatype float32, bitpix
    struct.pack_into("<8f", header, 76, 1.0, *spacing, 1, 1, 1, 1)  # pixdim
    struct.pack_into("<f", header, 108, 352.0)                  # vox_offset
    struct.pack_into("<ff", header, 112, 0.0, 0.0)              # scl_slope, scl_inter: none
    header[344:348] = b"n+1\0"
    with open(path, "wb") as f:
        f.write(header)
        f.write(values.astype("<f4").tobytes())


def same_bytes(name, input_args, pieces, extra=()):
    """The one-process store, then N ranks' for each N: identical files."""
    one = os.path.join(WORK, name + "_one.sdb")
    run(["import"] + input_args + ["-o", one, "--quiet", "--force"] + list(extra))
    want = open(one, "rb").read()
    for n in pieces:
        out = os.path.join(WORK, f"{name}_{n}.sdb")
        report = json.loads(run(["import"] + input_args + ["-o", out, "--json"] + list(extra), mpi=n).stdout)
        got = open(out, "rb").read()
        label = f"{name}, {n} ranks"
        if got != want:
            differ = next((i for i in range(min(len(got), len(want))) if got[i] != want[i]), min(len(got), len(want)))
            failures.append(f"{label}: {len(got)} bytes against one process's {len(want)}, first difference at {differ}")
        ranks = report.get("ranks", [])
        if n > 1 and (len(ranks) != n or sum(r["slabs"] for r in ranks) != report["windows"]):
            failures.append(f"{label}: the report's ranks {ranks} do not cover its {report['windows']} slabs")
        slabs = [r["slabs"] for r in ranks]
        print(f"{label}: {len(got)} bytes, {report['windows']} slabs as {slabs}, "
              f"{sum(r['payload_bytes_sent'] for r in ranks)} bytes exchanged")
        if n == max(pieces):
            run(["verify", out, "--quiet"])
    return want


def outputs(folder, name):
    """The files of `folder` that belong to output `name`: it and its
    temporaries."""
    return sorted(f for f in os.listdir(folder) if f == name or f.startswith(name + ".tmp."))


def full_disk(ht):
    """Two ranks writing to a 256 KiB tmpfs: one message naming a rank,
    the output and the cause; nothing left there. Skipped (with a line
    saying so) where mounting is not allowed."""
    disk = os.path.join(WORK, "disk")
    os.makedirs(disk)
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=256k", "tmpfs", disk],
                      capture_output=True).returncode != 0:
        print("full disk: cannot mount a small tmpfs here, not tested")
        return
    try:
        out = os.path.join(disk, "full.sdb")
        p = run(["import", ht, "-o", out], mpi=2, expect=(1,))
        messages = [line for line in p.stderr.splitlines() if line.startswith("simplexdb:")]
        if (len(messages) != 1 or " of 2" not in messages[0] or out not in messages[0]
                or "No space left" not in messages[0]):
            failures.append(f"a full disk: expected one message naming a rank, {out} and the cause, got "
                            f"{p.stderr!r}")
        if os.listdir(disk):
            failures.append(f"a full disk left {os.listdir(disk)}")
        print(f"full disk: {messages}")
    finally:
        subprocess.run(["umount", disk])


def rank_pids(out):
    """{rank: pid} of the running `simplexdb import ... -o out` processes."""
    found = {}
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                args = f.read().split(b"\0")
            if os.path.basename(args[0]) != b"simplexdb" or out.encode() not in args:
                continue
            with open(f"/proc/{pid}/environ", "rb") as f:
                env = dict(e.split(b"=", 1) for e in f.read().split(b"\0") if b"=" in e)
            if b"OMPI_COMM_WORLD_RANK" in env:
                found[int(env[b"OMPI_COMM_WORLD_RANK"])] = int(pid)
        except (OSError, IndexError):
            continue
    return found


def killed_rank():
    """Rank 1 of 2 killed (SIGKILL) while rank 0 writes its temporary: no
    store under the name; the next run of the same output builds it, and
    then only the store remains (a killed run's temporary is removed)."""
    volume = os.path.join(WORK, "kill.nrrd")
    run(["generate", "--field", "perlin", "--dims", "257,257,257", "--type", "float32", "--seed", "3",
         "-o", volume, "--quiet"])
    out = os.path.join(WORK, "kill.sdb")
    command = [MPIRUN, "--oversubscribe", "-np", "2", CLI, "import", volume, "-o", out, "--quiet"]
    p = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV)
    deadline = time.monotonic() + 60
    pids = {}
    while time.monotonic() < deadline and p.poll() is None:
        pids = rank_pids(out)
        if len(pids) == 2 and any(f.startswith("kill.sdb.tmp.") for f in os.listdir(WORK)):
            break
        time.sleep(0.02)
    if p.poll() is not None or len(pids) != 2:
        p.kill()
        p.communicate()
        failures.append(f"a killed rank: the build ended (or its ranks were not found: {pids}) before the kill")
        return
    time.sleep(0.2)
    os.kill(pids[1], signal.SIGKILL)
    _, err = p.communicate(timeout=120)
    if p.returncode == 0:
        failures.append("a killed rank: mpirun exited 0")
    if os.path.exists(out):
        failures.append(f"a killed rank left a store {out}")
    # mpirun may return before the rank it stopped has exited; the next
    # run removes only the temporaries of processes that no longer run.
    deadline = time.monotonic() + 60
    while rank_pids(out) and time.monotonic() < deadline:
        time.sleep(0.05)
    if rank_pids(out):
        failures.append(f"a killed rank: ranks {rank_pids(out)} still run a minute after mpirun exited")
        return
    print(f"killed rank 1: mpirun exit {p.returncode}, left {outputs(WORK, 'kill.sdb')}")
    run(["import", volume, "-o", out, "--quiet"], mpi=2)
    run(["verify", out, "--quiet"])
    if outputs(WORK, "kill.sdb") != ["kill.sdb"]:
        failures.append(f"after a killed rank, the next run left {outputs(WORK, 'kill.sdb')}")


def generated_field():
    """import --field: no file; each rank computes its own planes. The
    ranks' store is the one process's byte for byte, and both hold the
    values of the NRRD `generate` writes with the same options (the stores
    differ only in the header, which names the source)."""
    for dims, kind, ranks in (("61,53,140", "uint8", [2, 3]), ("17,17,17,40", "float32", [2])):
        field = ["--field", "perlin", "--dims", dims, "--type", kind, "--seed", "6"]
        nrrd = os.path.join(WORK, "generated.nrrd")
        run(["generate", "-o", nrrd, "--force", "--quiet"] + field[:6] + ["--seed", "6"])
        from_file = os.path.join(WORK, "generated_file.sdb")
        run(["import", nrrd, "-o", from_file, "--quiet", "--force"])
        want = same_bytes("generated_" + kind, [], ranks, field)
        got = open(from_file, "rb").read()
        if len(got) != len(want) or got[4096:] != want[4096:]:
            failures.append(f"import --field {dims} {kind}: not the values of the generated file's store")


def main():
    # An interrupted run may have left its small disk mounted.
    subprocess.run(["umount", os.path.join(WORK, "disk")], capture_output=True)
    shutil.rmtree(WORK, ignore_errors=True)
    os.makedirs(WORK)
    rng = np.random.default_rng(7)

    # HT from NRRD, a slab count that does not divide among the ranks.
    ht = os.path.join(WORK, "ht.nrrd")
    run(["generate", "--field", "perlin", "--dims", "130,97,300", "--type", "uint8", "--seed", "4", "-o", ht,
         "--quiet"])
    want = same_bytes("ht", [ht], [1, 2, 3, 4])
    # One process, many windows (spooled): the same bytes as one window.
    many = os.path.join(WORK, "ht_windows.sdb")
    report = json.loads(run(["import", ht, "-o", many, "--json", "--memory-mb", "12"]).stdout)
    if report["windows"] < 3 or open(many, "rb").read() != want:
        failures.append(f"one process in {report['windows']} windows: not the one-window store's bytes")

    # Raw, big-endian uint16, non-cubic: the ranks read their planes by offset.
    raw = os.path.join(WORK, "field.raw")
    z, y, x = np.mgrid[0:200, 0:45, 0:70]
    field = (30000 + 20000 * np.sin(x / 9.0) * np.cos(y / 7.0 + z / 23.0) + rng.integers(0, 300, x.shape))
    field.astype(">u2").tofile(raw)
    same_bytes("raw", [raw, "--dims", "70,45,200", "--type", "uint16", "--endian", "big"], [2, 3])

    # NIfTI float32 with missing values (NaN): the missing path, where
    # every octave's errors are stored and availability crosses ranks.
    nii = os.path.join(WORK, "holes.nii")
    z, y, x = np.mgrid[0:160, 0:40, 0:50]
    values = np.sin(x / 5.0) + np.cos(y / 4.0) * np.sin(z / 11.0)
    values[rng.random(values.shape) < 0.01] = np.nan
    values[100:110, 10:20, :] = np.nan
    write_nifti(nii, values.astype(np.float32), (0.5, 0.5, 1.25))
    same_bytes("nifti", [nii], [2, 4])

    # HP: a Perlin time series long enough to cut, and the shared fMRI
    # (too short in time to cut: rank 0 builds it alone).
    hp = os.path.join(WORK, "hp.nrrd")
    run(["generate", "--field", "perlin", "--dims", "17,17,17,70", "--type", "uint8", "--seed", "2", "-o", hp,
         "--quiet"])
    same_bytes("hp", [hp], [2, 3, 4])
    same_bytes("fmri", [os.path.join(DATA, "fmri_example4d", "example4d.nii")], [2])

    # A rank that fails: an infinity in the last planes of a float field,
    # which only the last rank reads. One message, naming that rank and the
    # voxel; no store, no temporary.
    bad = os.path.join(WORK, "bad.raw")
    values = rng.random((300, 20, 30)).astype("<f4")
    values[290, 3, 4] = np.inf
    values.tofile(bad)
    out = os.path.join(WORK, "bad.sdb")
    p = run(["import", bad, "--dims", "30,20,300", "--type", "float32", "-o", out], mpi=2, expect=(1,))
    messages = [line for line in p.stderr.splitlines() if line.startswith("simplexdb:")]
    if len(messages) != 1 or "rank 1 of 2" not in messages[0] or "nf" not in messages[0]:
        failures.append(f"a failing rank: expected one message naming rank 1 and the value, got {messages}")
    left = sorted(f for f in os.listdir(WORK) if f.startswith("bad.sdb"))
    if left:
        failures.append(f"a failing rank left {left}")

    generated_field()
    full_disk(ht)
    killed_rank()

    # The sparse store is built by one process: refused once.
    p = run(["import", ht, "--sparse", "-o", os.path.join(WORK, "sparse.sdb")], mpi=2, expect=(2,))
    if "--sparse" not in p.stderr or p.stderr.count("simplexdb:") != 1:
        failures.append(f"import --sparse under mpirun: {p.stderr!r}")

    for f in failures:
        print("FAILED:", f, file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
