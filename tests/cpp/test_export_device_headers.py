"""Exported programs compile against the public SCAMP-5d device headers, not only the shim.

The headers are never kept in this repository: ``PPALOC_SCAMP5_HEADERS`` names their
``include`` folder (the one holding ``s5d_m0/``, as in luozhongrui/scamp5_algorithms);
without it the tests skip, saying so.
docs/cpp.md ("Export") gives the flags and the stand-in for the ARM CMSIS header.
"""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

from ppaloc.cpp import Tracer, to_cpp
from ppaloc.cpp.export import kernel_to_cpp
from ppaloc.onsensor import OnSensorLocaliser
from ppaloc.sim import NEWS, R5, R6, R7, A, B, C, Scamp5, east

# The ARM CMSIS instruction intrinsics the device configuration includes
# (core_cmInstr.h, from ARM's toolchain): empty stand-ins for a syntax check.
CMSIS_STANDIN = "".join(
    f"static inline void {name}(void) {{}}\n"
    for name in ("__NOP", "__ISB", "__DSB", "__DMB", "__SEV", "__WFE", "__WFI")
)
DEVICE = ["-D__LPC43XX__", "-DCORE_M0"]  # the M0 core of the LPC43xx: the device's build


@pytest.fixture(scope="module")
def headers(cxx, tmp_path_factory) -> tuple[Path, Path]:
    """The device headers' include folder, and a folder with the CMSIS stand-in."""
    given = os.environ.get("PPALOC_SCAMP5_HEADERS")
    if not given:
        pytest.skip("no SCAMP-5d device headers: set PPALOC_SCAMP5_HEADERS to their include folder")
    include = Path(given)
    if not (include / "s5d_m0" / "scamp5.hpp").is_file():
        pytest.fail(f"PPALOC_SCAMP5_HEADERS={given} holds no s5d_m0/scamp5.hpp")
    cmsis = tmp_path_factory.mktemp("cmsis")
    (cmsis / "core_cmInstr.h").write_text(CMSIS_STANDIN)
    return include, cmsis


def syntax(cxx: str, headers: tuple[Path, Path], source: Path, defines: list[str]) -> str:
    """The compiler's errors for ``source`` against the device headers ('' when none)."""
    include, cmsis = headers
    args = [cxx, "-std=c++11", "-fsyntax-only", *defines, f"-I{include / 's5d_m0'}",
            f"-I{include}", f"-I{cmsis}", str(source)]  # fmt: skip
    done = subprocess.run(args, capture_output=True, text=True)
    return done.stderr if done.returncode else ""


def test_an_exported_kernel_with_raw_words_compiles_for_the_device(cxx, headers, tmp_path):
    sim = Scamp5(8, 8)
    with sim.kernel() as k:
        k.movx(A, B, east)
        k.add(C, A, B)
        k.sq(B)  # a raw word: icw(SCAMP5_CLOCK_ANALOG, {selsq, ...})
        k.bus(C, NEWS)
        k.XOR(R5, R6, R7)  # the device's AND/NOR calls
    text = kernel_to_cpp(k, "edges")
    assert "icw(SCAMP5_CLOCK_ANALOG" in text
    path = tmp_path / "kernel.cpp"
    path.write_text("#include <scamp5.hpp>\nusing namespace SCAMP5_PE;\n" + text)
    assert syntax(cxx, headers, path, DEVICE) == ""


def test_an_exported_pipeline_compiles_for_the_device_and_its_simulator(cxx, headers, tmp_path):
    rng = np.random.default_rng(4)
    places = [rng.integers(0, 256, (64, 64), dtype=np.uint8) for _ in range(3)]
    topomap = OnSensorLocaliser("lbp", size=64).build_map(places)
    tracer = Tracer()
    loc = OnSensorLocaliser("lbp", size=64, observers=[tracer])
    loc.use_map(topomap)
    estimates = [loc.step(f) for f in places[:2]]
    source = to_cpp(
        tracer.trace_of(loc.pipeline.sim), estimates=[(e.node, e.score) for e in estimates]
    )
    path = tmp_path / "pipeline.cpp"
    path.write_text(source)
    assert syntax(cxx, headers, path, DEVICE) == ""
    assert syntax(cxx, headers, path, []) == ""  # the device simulator's configuration
