"""benchmarks/eval_robust.py ends its pool's workers when it is sent SIGTERM."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import pytest

from .conftest import BENCHMARKS

# A stand-in for the script: its pool with two workers, each busy with an hour-long route,
# waited for as the script waits. With "thread" a thread other than the main one takes the
# SIGTERM, as the kernel may choose: Python then only marks the handler due, and a main
# thread asleep until a route ends never ran it (the script and its workers ran on).
CHILD = r"""
import multiprocessing, signal, sys, threading, time
sys.path.insert(0, sys.argv[1])
import eval_robust

with eval_robust.route_pool(2) as pool:
    busy = [pool.submit(time.sleep, 3600) for _ in range(2)]
    print(*[child.pid for child in multiprocessing.active_children()], flush=True)
    if sys.argv[2] == "thread":
        def take():  # once the main thread sleeps in the wait
            time.sleep(1)
            signal.pthread_kill(threading.get_ident(), signal.SIGTERM)
        threading.Thread(target=take).start()
    for _ in eval_robust.completed(busy):
        pass
"""


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
@pytest.mark.parametrize("taken_by", ["main", "thread"])
def test_sigterm_ends_the_pools_workers_too(taken_by):
    # SIGTERM ended the script alone, and its workers waited idle for over an hour
    proc = subprocess.Popen(
        [sys.executable, "-c", CHILD, str(BENCHMARKS), taken_by],
        stdout=subprocess.PIPE,
        text=True,
    )
    workers: list[int] = []
    try:
        workers = [int(p) for p in proc.stdout.readline().split()]
        assert len(workers) == 2
        if taken_by == "main":
            proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=120) == -signal.SIGTERM
        assert [pid for pid in workers if _alive(pid)] == []
    finally:
        for pid in [proc.pid, *workers]:
            if _alive(pid):
                os.kill(pid, signal.SIGKILL)
        proc.wait()
        proc.stdout.close()
