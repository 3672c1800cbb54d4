"""benchmarks/eval_robust.py ends its pool's workers when it is sent SIGTERM."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import pytest

from .conftest import BENCHMARKS

# A stand-in for the script: its pool with two workers, each busy with an hour-long route.
CHILD = r"""
import multiprocessing, sys, time
sys.path.insert(0, sys.argv[1])
import eval_robust

with eval_robust.route_pool(2) as pool:
    busy = [pool.submit(time.sleep, 3600) for _ in range(2)]
    print(*[child.pid for child in multiprocessing.active_children()], flush=True)
    busy[0].result()
"""


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_sigterm_ends_the_pools_workers_too():
    # SIGTERM ended the script alone, and its workers waited idle for over an hour
    proc = subprocess.Popen(
        [sys.executable, "-c", CHILD, str(BENCHMARKS)], stdout=subprocess.PIPE, text=True
    )
    workers: list[int] = []
    try:
        workers = [int(p) for p in proc.stdout.readline().split()]
        assert len(workers) == 2
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=120) == -signal.SIGTERM
        assert [pid for pid in workers if _alive(pid)] == []
    finally:
        for pid in [proc.pid, *workers]:
            if _alive(pid):
                os.kill(pid, signal.SIGKILL)
        proc.wait()
        proc.stdout.close()
