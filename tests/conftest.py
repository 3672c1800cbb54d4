"""Fixtures shared by the whole suite."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest
from hypothesis import settings

# Locally, hypothesis explores new examples on every run; under CI (CI set) the examples
# are derived from each test's name, so a run is reproducible and a failure can be re-run.
# No per-example deadline in either: on a loaded two-core machine one example of pure
# numpy can stall past hypothesis's 200 ms and fail a test that holds (speed targets live
# in benchmarks/).
settings.register_profile("ppaloc", deadline=None)
settings.register_profile("ci", parent=settings.get_profile("ppaloc"), derandomize=True)
settings.load_profile("ci" if os.environ.get("CI") else "ppaloc")


# The compiled engine's fused tier compiles each stretch it fuses (about 0.1 s an ICW, once
# per machine): the suite runs the first tier, and the tests of the fused tier (in
# tests/sim/test_engines.py and test_fused.py) fuse what they run. `PPALOC_FUSE_AFTER=1
# pytest` runs the whole suite fused.
os.environ.setdefault("PPALOC_FUSE_AFTER", "never")


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption(
        "--engine",
        default=None,
        help="simulator engine every Scamp5 uses by default (reference, numpy, compiled); "
        "the same as setting PPALOC_ENGINE",
    )


def pytest_configure(config: pytest.Config) -> None:
    engine = config.getoption("--engine")
    if engine:  # read by ppaloc.sim.engines.default_engine, in xdist workers too
        os.environ["PPALOC_ENGINE"] = engine


PROJECT_ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = PROJECT_ROOT.parent / "shared" / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """``../shared/data`` (real dataset copies); skips the test where it is absent."""
    if not SHARED_DATA.is_dir():
        pytest.skip("../shared/data is not present")
    return SHARED_DATA


def _dataset_dir(shared_data: Path, name: str) -> Path:
    path = shared_data / name
    if not path.is_dir():
        pytest.skip(f"../shared/data/{name} is not present")
    return path


@pytest.fixture(scope="session")
def nordland_dir(shared_data: Path) -> Path:
    """``../shared/data/nordland-64x32``; skips where absent."""
    return _dataset_dir(shared_data, "nordland-64x32")


@pytest.fixture(scope="session")
def gardens_point_dir(shared_data: Path) -> Path:
    """``../shared/data/gardens-point``; skips where absent."""
    return _dataset_dir(shared_data, "gardens-point")


@pytest.fixture(scope="session")
def dump_dom():
    """``dump_dom(url, budget_ms)``: the page's DOM after headless Chromium has run it for
    ``budget_ms`` of virtual time (``subprocess.CompletedProcess``: the DOM on stdout);
    skips where Chromium is not installed (``make test`` installs it)."""
    import shutil
    import subprocess
    import tempfile

    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        pytest.skip("chromium is not installed")

    def run(url: str, budget_ms: int) -> subprocess.CompletedProcess:
        with tempfile.TemporaryDirectory() as profile:
            return subprocess.run(
                [
                    chromium,
                    "--headless",
                    "--no-sandbox",
                    "--disable-gpu",
                    "--disable-background-networking",
                    "--disable-component-update",
                    "--disable-sync",
                    "--no-first-run",
                    f"--user-data-dir={profile}",
                    f"--virtual-time-budget={budget_ms}",
                    "--dump-dom",
                    url,
                ],
                capture_output=True,
                text=True,
                timeout=60,
                check=False,
            )

    return run


#: ``ppaloc`` as a command started from a shell: no signal blocked and SIGINT raising
#: KeyboardInterrupt, whatever the test process has inherited or been left with (a
#: blocked or ignored SIGINT passes to a child and would keep a Ctrl-C test's child from
#: ever seeing the signal).
PPALOC_AS_FROM_A_SHELL = (
    "import signal, sys; signal.pthread_sigmask(signal.SIG_SETMASK, ()); "
    "signal.signal(signal.SIGINT, signal.default_int_handler); "
    "from ppaloc.cli import main; sys.exit(main())"
)


@pytest.fixture(scope="session")
def ppaloc_command() -> list[str]:
    """The command that runs ``ppaloc`` in a child process with a shell's signal state."""
    return [sys.executable, "-c", PPALOC_AS_FROM_A_SHELL]


def _signal_state(pid: int) -> str:
    """A process's blocked and ignored signal masks (Linux), for a Ctrl-C test's message."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return "(no signal state)"
    return " ".join(line for line in status.splitlines() if line.startswith(("SigBlk", "SigIgn")))


@pytest.fixture(scope="session")
def signal_state():
    """``signal_state(pid)``: the process's blocked and ignored signals, as a string."""
    return _signal_state
