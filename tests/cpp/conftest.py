"""Fixtures of the C++ tests: a compiler or a clear skip, and the test programs."""

from __future__ import annotations

import json
import time
import urllib.error
import urllib.request
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import pytest

from ppaloc.cpp.build import compiler
from ppaloc.sim import Scamp5
from ppaloc.sim import registers as reg

PROGRAMS = Path(__file__).resolve().parent / "programs"
T = TypeVar("T")


@pytest.fixture(scope="session")
def engine_compiled() -> None:
    """The simulator's default engine run once, so that a test's deadline times the
    program and its page, not the engine's first compile (tens of seconds on a machine
    whose numba cache is empty, as a fresh clone's is)."""
    sim = Scamp5(8, 8)
    with sim.kernel() as k:
        k.icw("bus", (reg.NEWS,), (reg.A,))


@pytest.fixture(scope="session")
def cxx(request: pytest.FixtureRequest) -> str:
    """The C++ compiler; skips where the machine has none. The programs it builds run on
    the simulator, whose engine is compiled first (:func:`engine_compiled`)."""
    found = compiler()
    if found is None:
        pytest.skip("no C++ compiler (g++) here: install Debian's g++ package (make test does)")
    request.getfixturevalue("engine_compiled")  # only where a program will run
    return found


WAIT_S = 60.0
"""How long a live view's test waits for what it expects: a compile and the first frames
on a loaded machine take seconds; a passing run returns as soon as it is there."""


def wait_until(ready: Callable[[], T | None], what: str, seconds: float = WAIT_S) -> T:
    """``ready()``'s first true value, polled every 10 ms, or an AssertionError naming
    ``what`` after ``seconds`` (a deadline on the clock, not a count of polls that a busy
    machine stretches or cuts short)."""
    deadline = time.monotonic() + seconds
    while True:
        got = ready()
        if got:
            return got
        if time.monotonic() > deadline:
            raise AssertionError(f"the live view never {what} (waited {seconds:.0f} s)")
        time.sleep(0.01)


class LiveClient:
    """Talks to a live view over HTTP once it has announced its URL into :attr:`urls`."""

    urls: list[str]

    @property
    def url(self) -> str:
        return wait_until(lambda: self.urls[0] if self.urls else None, "announced its URL")

    def post(self, body, kind: str = "application/json") -> tuple[int, str]:
        """POST ``body`` (a dict as JSON, or raw bytes) to ``set``: (status, answer)."""
        data = body if isinstance(body, bytes) else json.dumps(body).encode()
        req = urllib.request.Request(self.url + "set", data=data, headers={"Content-Type": kind})
        try:
            with urllib.request.urlopen(req, timeout=10) as r:
                return r.status, r.read().decode()
        except urllib.error.HTTPError as err:
            return err.code, err.read().decode()
