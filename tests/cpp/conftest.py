"""Fixtures of the C++ tests: a compiler or a clear skip, and the test programs."""

from __future__ import annotations

import json
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest

from ppaloc.cpp.build import compiler

PROGRAMS = Path(__file__).resolve().parent / "programs"


@pytest.fixture(scope="session")
def cxx() -> str:
    """The C++ compiler; skips where the machine has none."""
    found = compiler()
    if found is None:
        pytest.skip("no C++ compiler (g++) here: install Debian's g++ package (make test does)")
    return found


class LiveClient:
    """Talks to a live view over HTTP once it has announced its URL into :attr:`urls`."""

    urls: list[str]

    @property
    def url(self) -> str:
        for _ in range(600):
            if self.urls:
                return self.urls[0]
            time.sleep(0.01)
        raise AssertionError("the live view never announced its URL")

    def post(self, body, kind: str = "application/json") -> tuple[int, str]:
        """POST ``body`` (a dict as JSON, or raw bytes) to ``set``: (status, answer)."""
        data = body if isinstance(body, bytes) else json.dumps(body).encode()
        req = urllib.request.Request(self.url + "set", data=data, headers={"Content-Type": kind})
        try:
            with urllib.request.urlopen(req, timeout=10) as r:
                return r.status, r.read().decode()
        except urllib.error.HTTPError as err:
            return err.code, err.read().decode()
