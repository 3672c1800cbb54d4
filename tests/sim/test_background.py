"""The fused tier's background compiles never outlive the process that asked for them."""

from __future__ import annotations

import signal
import subprocess
import sys
import time

import pytest

pytest.importorskip("numba")

from ppaloc.sim.engines import fused

SLEEPER = [sys.executable, "-c", "import time; time.sleep(120)"]


def _alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie, ended but not yet reaped, counts as gone)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            state = f.read().rsplit(")", 1)[1].split()[0]
    except FileNotFoundError:
        return False
    return state not in ("Z", "X")


def _gone_within(pid: int, seconds: float) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if not _alive(pid):
            return True
        time.sleep(0.05)
    return False


def test_stop_ends_the_running_compile_and_drops_the_queue():
    bg = fused.Background()
    bg._queue += [("a", SLEEPER), ("b", SLEEPER)]
    bg.poll()
    proc = bg._running
    assert proc is not None and proc.poll() is None
    assert bg.stop() == 2  # the running one and the queued one
    assert proc.poll() is not None and bg._running is None and not bg._queue
    assert bg.stop() == 0


def test_drain_runs_the_queue_in_the_foreground():
    bg = fused.Background()
    bg._queue += [(str(i), [sys.executable, "-c", "pass"]) for i in range(3)]
    seen = []
    assert bg.drain(lambda done, total: seen.append((done, total))) == 3
    assert seen == [(1, 3), (2, 3), (3, 3)] and bg._running is None


def test_a_compile_dies_with_the_process_that_started_it():
    """The parent killed outright (no atexit): the compile process ends too (Linux)."""
    if not sys.platform.startswith("linux"):
        pytest.skip("the parent-death signal is Linux's")
    child = (
        "from ppaloc.sim.engines.fused import _die_with_parent; _die_with_parent(); "
        "import time; time.sleep(120)"
    )
    parent = (
        "import os, subprocess, sys, time; "
        f"env = {{**os.environ, {fused.PARENT_ENV!r}: str(os.getpid())}}; "
        f"p = subprocess.Popen([sys.executable, '-c', {child!r}], env=env); "
        "print(p.pid, flush=True); time.sleep(120)"
    )
    proc = subprocess.Popen([sys.executable, "-c", parent], stdout=subprocess.PIPE, text=True)
    try:
        pid = int(proc.stdout.readline())
        time.sleep(0.5)  # before or after the child has asked to follow its parent: either way
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
        assert _gone_within(pid, 30), "the compile outlived its parent"
    finally:
        proc.kill()
        proc.wait()
        proc.stdout.close()
