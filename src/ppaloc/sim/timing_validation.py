"""Published SCAMP-5 times of whole programs, to check the timing model against.

A validation workload is a program whose time was measured on SCAMP-5 hardware and
published, rebuilt here as a count vector (ICWs by clock class, kernel runs, controller
calls and their units; :func:`ppaloc.sim.timing.evaluate_us`) plus any controller-side
work outside the count model, given as its own low/mid/high estimate. Its modelled
interval comes from the corners of :class:`~ppaloc.sim.timing.TimingConstants`, as every
on-sensor frame's does, so a published time inside the interval is a check of the whole
table, not of one constant.

Each workload keeps apart the counts whose time a calibration fixes (``fitted``: at every
corner they cost what was measured) from the rest (``unfitted``): only the second part
tests the model. :data:`CANDIDATES` lists the published figures that were considered and
why none of them is a workload here (docs/onsensor.md, "Timing").

Examples
--------
>>> w = ANALOGNET_FRAME
>>> round(w.published_us, 1)  # 2260 frames per second
442.5
>>> iv = w.interval()
>>> iv.low <= w.published_us <= iv.high
True
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

from ppaloc.sim.timing import (
    ANALOGNET_STAGES,
    DEFAULT_CLOCK_HZ,
    Interval,
    TimingConstants,
    TimingError,
    add_counts,
    interval_us,
)

__all__ = [
    "ANALOGNET_FRAME",
    "CANDIDATES",
    "WORKLOADS",
    "Candidate",
    "Workload",
    "program_counts",
]


def program_counts(kernels: list[Mapping[str, int]], calls: list[tuple[str, float]]) -> dict:
    """Count vector of a program given as kernels (ICWs by class) and ``(call, units)``."""
    counts = [{f"icw:{c}": float(n) for c, n in k.items() if n} for k in kernels]
    if kernels:
        counts.append({"kernels": float(len(kernels))})
    for name, units in calls:
        counts.append({f"calls:{name}": 1.0, **({f"units:{name}": float(units)} if units else {})})
    return add_counts(*counts)


@dataclass(frozen=True)
class Workload:
    """One published SCAMP-5 time and the program it measured, as counts.

    Attributes
    ----------
    name : str
        What the program does, in a few words.
    source : str
        Where the time was published (paper, section or abstract).
    published_us : float
        The published time, microseconds.
    fitted : Mapping[str, float]
        Counts whose time a calibration fixes at every corner (the part that tests nothing).
    fitted_published_us : float
        The measured time the calibration gives ``fitted`` at every corner, microseconds.
    unfitted : Mapping[str, float]
        Counts no constant was fitted to.
    host_us : tuple[float, float, float]
        Controller-side work outside the count model (low, mid, high), microseconds.
    host_note : str
        What ``host_us`` estimates and how.
    independent : str
        Whether, and how far, the published time is independent of the fit.
    """

    name: str
    source: str
    published_us: float
    fitted: Mapping[str, float]
    fitted_published_us: float
    unfitted: Mapping[str, float]
    host_us: tuple[float, float, float]
    host_note: str
    independent: str

    def __post_init__(self) -> None:
        lo, mid, hi = self.host_us
        if not 0 <= lo <= mid <= hi:
            raise TimingError(
                f"Workload {self.name!r}: host_us={self.host_us!r} is invalid: use "
                "(low, mid, high) with 0 <= low <= mid <= high"
            )

    def counts(self) -> dict[str, float]:
        """The whole program's count vector (fitted and unfitted parts)."""
        return add_counts(self.fitted, self.unfitted)

    def interval(
        self, constants: TimingConstants | None = None, clock_hz: float = DEFAULT_CLOCK_HZ
    ) -> Interval:
        """Modelled time of the whole program (us): the counts' interval plus ``host_us``."""
        return interval_us(self.counts(), constants, clock_hz) + Interval(*self.host_us)

    def unfitted_interval(
        self, constants: TimingConstants | None = None, clock_hz: float = DEFAULT_CLOCK_HZ
    ) -> Interval:
        """Modelled time of the part no constant was fitted to (us), ``host_us`` included."""
        return interval_us(self.unfitted, constants, clock_hz) + Interval(*self.host_us)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready entry of ``eval_timing.py --json``'s ``"validation"`` list."""
        whole = self.interval()
        part = self.unfitted_interval()
        fitted = self.fitted_published_us
        return {
            "workload": self.name,
            "source": self.source,
            "published_us": self.published_us,
            "modelled_us": whole.as_list(),
            "independent": self.independent,
            "unfitted_part": {
                "published_us": self.published_us - fitted,
                "modelled_us": part.as_list(),
                "note": f"the published time minus the fitted part ({fitted:g} us, measured, "
                "which every corner reproduces); " + self.host_note,
            },
        }


def _analognet_frame() -> Workload:
    stages = [program_counts(p["kernels"], p["calls"]) for p in ANALOGNET_STAGES.values()]
    # the dense layer on the controller: 100-300 events read out (200 mid), each adding one
    # weight to 10 class sums at 2-6 cycles per accumulate (4 mid) on the 204 MHz core
    dense = tuple(e * 10 * c / 204.0 for e, c in ((100, 2), (200, 4), (300, 6)))
    return Workload(
        name="AnalogNet MNIST inference, whole frame (3 fitted on-array stages + frame-loop "
        "control + dense layer on the controller)",
        source="Wong et al., AnalogNet, arXiv:2006.01765 (2020), abstract: 2260 FPS",
        published_us=1e6 / 2260.0,
        fitted=MappingProxyType(add_counts(*stages)),
        fitted_published_us=sum(p["measured_us"] for p in ANALOGNET_STAGES.values()),
        unfitted=MappingProxyType({"calls:vs_frame_loop_control": 1.0}),
        host_us=dense,
        host_note="unfitted: one vs_frame_loop_control and the dense layer on the controller "
        "(an estimate: 100-300 events x 10 class sums x 2-6 cycles at 204 MHz)",
        independent="partly: the three stages (354 us) are the calibration; the frame-loop "
        "control and the dense-layer estimate are not fitted",
    )


#: AnalogNet's whole frame: the only published whole-program SCAMP-5 time found whose
#: program is public; its three stages are the calibration (:data:`ANALOGNET_STAGES`).
ANALOGNET_FRAME = _analognet_frame()

#: Every validation workload, in the order ``eval_timing.py`` prints them.
WORKLOADS: tuple[Workload, ...] = (ANALOGNET_FRAME,)


@dataclass(frozen=True)
class Candidate:
    """A published SCAMP-5 time that was considered and not made a workload, and why."""

    name: str
    source: str
    published: str
    reason: str


#: The published figures considered for validation and not used (each with its source and
#: the reason); figures as the abstracts, READMEs and code searched state them.
CANDIDATES: tuple[Candidate, ...] = (
    Candidate(
        "BIT-VO: 6-DoF visual odometry from binary edges and corners",
        "Murai, Saeedi, Kelly, arXiv:2004.11186 (2020), abstract",
        "300 FPS, the entire system",
        "a whole-system rate with the odometry on the host; the SCAMP-5 program (feature "
        "extraction and readout) is not in the public code found",
    ),
    Candidate(
        "Marker odometry and BIT-VO",
        "Murai, Saeedi, Kelly, Autonomous Robots 47:1579-1592 (2023), abstract",
        "over 400 FPS (marker), 300 FPS (BIT-VO)",
        "whole-system rates (one a bound) with the odometry on the host; the SCAMP-5 "
        "program is not in the public code found",
    ),
    Candidate(
        "MNIST CNN entirely on the array",
        "Bose et al., 'Fully Embedding Fast Convolutional Networks on Pixel Processor "
        "Arrays', ECCV 2020, arXiv:2004.12525, abstract",
        "over 3000 frames per second",
        "a bound, not a time; the public code (lauriebose/Scamp5-MNIST_AREG_CNN_example) "
        "is dated 2021, after the paper, so not shown to be the program measured; it "
        "displays images every frame, runs a GUI-set number of FC passes and uses "
        "scamp5_flood and scamp5_global_sum_sparse, which have no public cost",
    ),
    Candidate(
        "Strided-convolution CNNs, 4 applications",
        "Liu, Bose, Chen, Carey, Dudek, Mayol-Cuevas, BMVC 2020, abstract",
        "between 2,000 and 17,500 fps",
        "the rate of each application is in the paper's body, not in the abstract "
        "searched; no public code found",
    ),
    Candidate(
        "Closed-shape object location on the SCAMP-5 chip",
        "Carey, Lopich, Barr, Wang, Dudek, VLSI Circuits 2013, abstract",
        "100,000 fps",
        "the program is not described at the level of ICWs and controller calls in the "
        "abstract, the only part searched",
    ),
    Candidate(
        "AUKE-generated convolution kernels",
        "Debrunner, Saeedi, Kelly, ACM Trans. Archit. Code Optim. 15 (2019), abstract",
        "speed and energy 'for a suite of well-known convolution filters' (no figure in "
        "the abstract)",
        "any measured times are in the paper's body, not in the abstract searched; the "
        "public generator (ThomasDebrunner/auto_code_cpa) holds no measurements",
    ),
    Candidate(
        "Cain-generated convolution kernels",
        "Stow et al., arXiv preprint (2021) and Autonomous Robots 46:893-910 (2022), abstracts",
        "instruction counts only ('half as long')",
        "no time in the abstracts; the public compiler (ed741/cain) holds no measurements",
    ),
    Candidate(
        "AnalogNet variants (2-layer, max-pooled, depth-separable)",
        "Guillard, MSc thesis code (public SCAMP-5 ports)",
        "'15 fps network' in the headers",
        "a rate set by vs_configure_frame_trigger(VS_FRAME_TRIGGER_CONST_LOOP, 12), not a "
        "compute time",
    ),
    Candidate(
        "Kernel-length cost tutorial",
        "lauriebose/Scamp5-Tutorial-Examples, EX_KERNEL_COST.hpp",
        "none (prints the time of 100 shifts in kernels of 2-200 ICWs on the device)",
        "a program made to measure the launch cost, with no published result",
    ),
    Candidate(
        "PixelRNN on SCAMP-5",
        "So, Bose, Dudek, Wetzstein, CVPR 2024 (computational-imaging/PixelRNN)",
        "none in the README",
        "no published time in the README or code searched",
    ),
    Candidate(
        "Visual odometry by on-array image alignment",
        "Bose et al., ICCV 2017; Greatwood et al., IROS 2018 (lauriebose/Scamp_image_alignment_VO)",
        "none in the repository's README",
        "the papers' text was not in the sources searched; the code holds no measurements",
    ),
)
