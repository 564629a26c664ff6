"""Where the runs go: local workers start at once, this process runs the first tasks until one is up, and a pool
whose workers cannot start leaves every run to this process, with a warning; results in the order of the tasks."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import pytest

from agvctl.checks.executors import LocalPool, execute, open_executor


def _where(task: float) -> tuple[float, int]:
    """The task after a pause of ``task`` seconds, and the process that ran it."""
    time.sleep(task)
    return task, os.getpid()


def test_this_process_runs_the_first_tasks_while_the_workers_start_and_the_workers_the_rest():
    tasks = [0.02 * (1 + k % 3) for k in range(150)]
    with open_executor("local", 2, None, len(tasks), prepare=__name__) as pool:
        assert isinstance(pool, LocalPool)
        results = execute(pool, _where, tasks, None)
    assert [r[0] for r in results] == tasks  # in the order of the tasks
    where = [r[1] for r in results]
    assert where[0] == os.getpid()  # a worker is not up at once
    assert set(where) - {os.getpid()}  # and the workers took the rest once they were
    first_elsewhere = next(k for k, pid in enumerate(where) if pid != os.getpid())
    assert all(pid != os.getpid() for pid in where[first_elsewhere:])


def test_workers_that_cannot_start_leave_every_run_to_this_process_with_a_warning():
    tasks = [0.0] * 5
    with (
        pytest.warns(RuntimeWarning, match="could not start"),
        open_executor("local", 2, None, len(tasks), prepare="agvctl.no_such_module") as pool,
    ):
        while isinstance(pool, LocalPool) and pool.failure is None:  # a worker fails to import it
            time.sleep(0.01)
        results = execute(pool, _where, tasks, None)
    assert results == [(0.0, os.getpid())] * 5


_MASKS = """
import os, signal, time
from agvctl.checks.executors import execute, open_executor

def blocked(pid):
    with open(f"/proc/{pid}/status", encoding="ascii") as f:
        mask = next(line for line in f if line.startswith("SigBlk:")).split()[1]
    return bool(int(mask, 16) >> (signal.SIGINT - 1) & 1)

with open_executor("local", 2, None, 40, prepare="time") as pool:
    execute(pool, time.sleep, [0.02] * 40, None)
    print([blocked(pid) for pid in pool._processes], blocked(os.getpid()))
print(blocked(os.getpid()))
"""


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="reads the signal mask from /proc")
def test_local_workers_block_sigint_so_an_interrupt_stops_only_this_process():
    # a fresh process: the first pool of a process also starts multiprocessing's resource tracker
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = {**os.environ, "PYTHONPATH": root}
    proc = subprocess.run([sys.executable, "-c", _MASKS], capture_output=True, text=True, env=env, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split("\n")[:2] == ["[True, True] False", "False"]  # workers blocked; this process not
