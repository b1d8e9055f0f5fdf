"""Start-up (issue 25): Open MPI's quick-start choices (pmpm.comm.launch) are made only
where they are safe and the user made none, a singleton and a 2-rank run start MPI with
them, and the process's start-up clock (pmpm.solver.startup) reads sensible values. The
command line's quick exits are tested in test_cli.py, the summary's ``startup_s`` in
test_cli.check_summary."""
import os
import subprocess
import sys

import pytest

from clihelp import ENV, ROOT
from pmpm.comm.launch import ONE_MACHINE, SINGLETON, quick_start_settings

MPIRUN_ONE_MACHINE = {"OMPI_COMM_WORLD_SIZE": "2", "OMPI_COMM_WORLD_LOCAL_SIZE": "2",
                      "OMPI_COMM_WORLD_RANK": "1"}


@pytest.mark.parametrize("environ, expected", [
    ({}, SINGLETON),                                           # python -m pmpm
    (MPIRUN_ONE_MACHINE, ONE_MACHINE),                         # mpirun on one machine
    (dict(MPIRUN_ONE_MACHINE, OMPI_COMM_WORLD_LOCAL_SIZE="1"), {}),   # spans machines
    ({"SLURM_PROCID": "0"}, {}),                               # srun: Slurm's choice
    ({"PMI_RANK": "0"}, {}),                                   # MPICH's Hydra
    ({"OMPI_MCA_pml": "ucx"}, {}),                             # the user's choices
    (dict(MPIRUN_ONE_MACHINE, OMPI_MCA_btl="self,tcp"), {}),
    ({"OMPI_MCA_mtl": "psm2"}, {}),
], ids=["singleton", "one machine", "two machines", "srun", "hydra", "user pml",
        "user btl", "user mtl"])
def test_quick_start_only_where_safe_and_unchosen(environ, expected):
    assert quick_start_settings(environ) == expected


#: each rank writes its line to its own file: two ranks' prints through mpirun's forwarded
#: stdout can arrive interleaved on a loaded machine
PROBE = ("import os, sys; from pmpm.comm.launch import quick_mpi_start\n"
         "with quick_mpi_start() as chosen:\n"
         "    from pmpm.comm import world; w = world()\n"
         "line = f\"{w.rank} {w.size} {w.sum(w.rank + 1)} {chosen.get('OMPI_MCA_pml')} "
         "{'OMPI_MCA_pml' in os.environ}\"\n"
         "open(os.path.join(sys.argv[1], f'rank{w.rank}'), 'w').write(line)")


@pytest.mark.parametrize("ranks", [1, 2])
def test_mpi_starts_with_the_quick_choices(ranks, tmp_path):
    """The choices start MPI and its collectives work (ob1 with only the self transport
    for a singleton, ob1 between the ranks of one machine), and the environment is left as it
    was (a singleton's btl=self inherited by an mpirun started later would cut its
    ranks off from each other)."""
    env = dict(os.environ, **ENV, PYTHONPATH=ROOT)
    for name in ("OMPI_MCA_pml", "OMPI_MCA_btl", "OMPI_MCA_mtl"):
        env.pop(name, None)
    cmd = [sys.executable, "-c", PROBE, str(tmp_path)]
    if ranks > 1:
        cmd = ["mpirun", "-n", str(ranks), "--oversubscribe"] + cmd
    done = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=60)
    assert done.returncode == 0, done.stderr
    lines = sorted((tmp_path / f"rank{rank}").read_text() for rank in range(ranks))
    total = ranks * (ranks + 1) // 2
    assert lines == [f"{rank} {ranks} {total} ob1 False" for rank in range(ranks)]


def test_the_startup_clock_counts_from_the_process_start():
    """A fresh process that sleeps 0.3 s reports at least that much wall time since it
    started, little CPU time and a queue no longer than its wall time."""
    code = ("import time; time.sleep(0.3); from pmpm.solver.startup import "
            "since_process_start as s; print(repr(s()))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=dict(os.environ, PYTHONPATH=ROOT), timeout=60)
    clock = eval(done.stdout)           # a dict of floats
    assert clock["wall"] >= 0.3 - 0.01                 # 10 ms ticks of the start time
    assert clock["wall"] < 30
    assert 0 < clock["cpu"] < clock["wall"]
    assert 0 <= clock["queued"] <= clock["wall"]
    assert clock["wall_less_queued"] == pytest.approx(clock["wall"] - clock["queued"])


WRITER = ("import sys, time, h5py; from pmpm.comm import world; w = world()\n"
          "for k in range(int(sys.argv[2])):\n"
          "    with h5py.File(f'{sys.argv[1]}_{k}.h5', 'w', driver='mpio', comm=w.raw) as f:\n"
          "        f['a'] = [k]\n"
          "    time.sleep(0.03)\n")


def test_singletons_side_by_side_write_without_complaint(tmp_path):
    """Three 1-rank runs at once on one machine, one ending before the others, open HDF5
    files through MPI-IO without an error line (an isolated singleton's shared session
    folder, deleted by the first to end, made the others print one per file)."""
    env = dict(os.environ, **ENV, PYTHONPATH=ROOT)
    for name in ("OMPI_MCA_pml", "OMPI_MCA_btl", "OMPI_MCA_mtl"):
        env.pop(name, None)
    runs = [subprocess.Popen([sys.executable, "-c", WRITER, str(tmp_path / f"w{k}"),
                              str(4 + 6 * k)], env=env, stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True) for k in range(3)]
    for run in runs:
        out, err = run.communicate(timeout=120)
        assert run.returncode == 0, err
        assert err == "", err
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        f"w{k}_{j}.h5" for k in range(3) for j in range(4 + 6 * k))
