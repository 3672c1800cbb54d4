"""Frame timing at two boundaries, and the precursor's program structure as counts.

Two boundaries per frame (docs/onsensor.md, "Timing"):

- ``chip``: the kernels and controller calls of the frame on the sensor's controller
  (what the simulator charges while the pipeline runs);
- ``loop``: ``chip`` plus what a hardware experiment on a dataset adds around it: the
  frame injected from the host (:func:`injection_counts`: 4 bit-planes requested with
  ``vs_gui_request_image`` and drawn into digital registers, then turned into an analogue
  image), ``vs_frame_loop_control`` and the estimate sent back (:func:`loop_counts`).

Two program structures for ``chip`` (``STRUCTURES``): ``"ppaloc"``, the simulated
pipeline's own counts, and ``"precursor"``, where the stages the public precursor of the
paper's code (``yananliusdu/SCAMP`` at 48d384f) programs differently are replaced by that
program's kernels and calls (:func:`precursor_stage_counts`): replication of the live 8x8
image by 64 DAC loads, in-block sums through ``scamp5_shift``, the snake shift of its
``move_forward``, and detection by a threshold loop of ``scan_events(300)`` passes with one
``scan_areg`` per event. Its kernels are recorded as real kernels on a small simulated
array (:func:`kernel_counts`) so that their ICW counts are the macro table's; the
per-frame call counts follow the precursor's source. It has no descriptor code (its
Hamming distance is commented out), so the descriptor variant reuses its in-block sum on
the XOR plane: an extrapolation, marked as such.

Counts are the vectors of :func:`ppaloc.sim.timing.evaluate_us` (``"icw:<class>"``,
``"kernels"``, ``"calls:<name>"``, ``"units:<name>"``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from functools import cache
from typing import Any

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.sim import FLAG, IN, R4, R5, R6, R7, R8, R9, R10, R12, A, B, C, D, E, Scamp5
from ppaloc.sim.timing import add_counts

__all__ = [
    "BIT_PLANES",
    "INJECTIONS",
    "REPLACED_STAGES",
    "STRUCTURES",
    "injection_counts",
    "kernel_counts",
    "loop_counts",
    "precursor_detect_counts",
    "precursor_stage_counts",
    "structure_counts",
]

#: Program structures of the ``chip`` boundary.
STRUCTURES = ("ppaloc", "precursor")

#: How the ``loop`` boundary's frame reaches the registers: drawn as the precursor does
#: it, or its bytes only (the least any path can cost).
INJECTIONS = ("drawn", "bytes")

#: Bit-planes the precursor requests per injected frame (its ``D2A_BITS``).
BIT_PLANES = 4

#: Threshold passes and event slots of the precursor's detection (``get_highest_values``:
#: ``Th = 63`` halved until some node is above it; ``NUMBER_OF_CORRECT_PARTICLES``).
PRECURSOR_THRESHOLDS = (63, 31, 15, 7, 3, 1)
PRECURSOR_EVENT_SLOTS = 300

#: Our stages the precursor structure replaces, by representation (its own stages are
#: added under the same names, and ``requantise`` is added).
REPLACED_STAGES: Mapping[str, tuple[str, ...]] = {
    "lowres": ("replicate", "compare", "shift", "detect"),
    "lbp": ("compare", "shift", "detect"),
}


def _k(**counts: int) -> dict[str, float]:
    return {f"icw:{c}": float(n) for c, n in counts.items() if n}


@cache
def kernel_counts(name: str) -> dict[str, float]:
    """ICW counts of one of the precursor's kernels, recorded on an 8x8 simulated array.

    ``name`` is a key of :data:`_KERNELS`; the result is a count vector with one kernel run.
    """
    try:
        body = _KERNELS[name]
    except KeyError:
        raise PpalocError(f"no precursor kernel {name!r}; known: {', '.join(_KERNELS)}") from None
    sim = Scamp5(rows=8, cols=8)
    with sim.kernel() as k:
        body(k)
    out = _k(**{c: int(n) for c, n in k.counts.items()})
    out["kernels"] = 1.0
    return out


# The precursor's kernels (register names as in its source: weights A, database D, live
# image E; R5/R6 masks), as bodies recorded by ``kernel_counts``.
_KERNELS: dict[str, Callable[[Any], None]] = {
    "all": lambda k: k.all(),
    "where_r5": lambda k: k.WHERE(R5),
    "where_mov_in": lambda k: (k.WHERE(R5), k.mov(A, IN)),
    "res_set_all": lambda k: (k.res(A), k.SET(R5), k.all()),
    "sub_abs_clr": lambda k: (k.all(), k.sub(B, D, E), k.abs(C, B), k.CLR(R5)),
    "sub_in": lambda k: k.sub(B, C, IN),
    "where_mov_flag_all": lambda k: (k.where(B), k.MOV(R5, FLAG), k.all()),
    "mov": lambda k: k.mov(B, C),
    "where_add": lambda k: (k.WHERE(R6), k.add(C, C, B)),
    "all_mov": lambda k: (k.all(), k.mov(B, C)),
    "where_mov": lambda k: (k.WHERE(R6), k.mov(C, B)),
    "where_sub_add": lambda k: (k.WHERE(R6), k.sub(B, IN, C), k.add(A, A, B)),
    "all_clr3": lambda k: (k.all(), k.CLR(R4), k.CLR(R5), k.CLR(R6)),
    "where_mov_all": lambda k: (k.WHERE(R6), k.mov(C, B), k.all()),
    "refresh4": lambda k: (k.REFRESH(R7), k.REFRESH(R8), k.REFRESH(R9), k.REFRESH(R10)),
    "digitise": lambda k: (k.all(), k.sub(B, E, C), k.SET(R12), k.where(B), k.MOV(R12, FLAG)),
    "mov_dreg": lambda k: k.MOV(R4, R12),
    "where_sub_all": lambda k: (k.WHERE(R12), k.sub(E, E, C), k.all()),
    "where_add_all": lambda k: (k.WHERE(R4), k.add(E, E, C), k.all()),
    "clr": lambda k: k.CLR(R4),
    "xor_to_areg": lambda k: (k.XOR(R4, R5, R9), k.WHERE(R4), k.mov(C, IN), k.all()),
    "detect_pass": lambda k: (k.all(), k.WHERE(R6), k.sub(B, C, IN), k.where(B), k.MOV(R5, FLAG)),
    "detect_setup": lambda k: (k.all(), k.mov(C, A)),
}


def _calls(*pairs: tuple[str, float]) -> dict[str, float]:
    out: dict[str, float] = {}
    for name, units in pairs:
        out[f"calls:{name}"] = out.get(f"calls:{name}", 0.0) + 1.0
        if units:
            out[f"units:{name}"] = out.get(f"units:{name}", 0.0) + float(units)
    return out


def _program(kernels: Sequence[str], calls: Sequence[tuple[str, float]] = ()) -> dict[str, float]:
    return add_counts(*(kernel_counts(k) for k in kernels), _calls(*calls))


def _in_block_sum(levels_h: Sequence[int], levels_v: Sequence[int]) -> dict[str, float]:
    """``sum_analog_reg``: thresholded copy, then add and spread levels by ``scamp5_shift``."""
    parts = [
        _program(
            ["all", "sub_in", "where_mov_flag_all", "where_mov_in"],
            [("load_in", 0), ("scamp5_in", 0), ("load_in", 0)],
        )
    ]
    for step in (*levels_h, *levels_v):  # add levels: ALL; pattern; copy; shift; masked add
        parts.append(
            _program(["all", "mov", "where_add"], [("load_pattern", 0), ("shift_areg", step)])
        )
    for step in (*sorted(levels_h), *sorted(levels_v)):  # spread levels: mask shifted too
        parts.append(
            _program(
                ["all_mov", "where_mov"],
                [("load_pattern", 0), ("shift_areg", step), ("shift_dreg", step)],
            )
        )
    return add_counts(*parts)


def precursor_detect_counts(weights: np.ndarray | None) -> dict[str, float]:
    """The precursor's detection for one frame's node weights (None: one pass, one event).

    Threshold passes at ``Th = 63, 31, ...`` until some node is above ``Th``; each pass a
    ``load_in``, a short masked compare, ``scan_events(300)`` and one ``scan_areg`` of one
    value (with an ``all()``) per returned event (at most 300).
    """
    passes, events = 1, 1
    if weights is not None and len(weights):
        w = np.asarray(weights, dtype=np.float64)
        for i, th in enumerate(PRECURSOR_THRESHOLDS):
            above = int(np.count_nonzero(w > th))
            passes, events = i + 1, min(above, PRECURSOR_EVENT_SLOTS)
            if above:
                break
    per_pass = add_counts(
        _calls(("load_in", 0), ("scan_events", PRECURSOR_EVENT_SLOTS)),
        {k: v for k, v in kernel_counts("detect_pass").items() if k != "kernels"},
    )
    per_event = add_counts(_calls(("scan_areg", 1)), _k(digital=1))
    return add_counts(
        _program(["detect_setup"], [("load_pattern", 0), ("scamp5_in", 0)]),
        {k: v * passes for k, v in per_pass.items()},
        {k: v * events for k, v in per_event.items() if events},
    )


def precursor_stage_counts(
    representation: str, *, forward: bool, weights: np.ndarray | None = None
) -> dict[str, dict[str, float]]:
    """The precursor's stages of one frame, by stage name (count vectors).

    ``requantise``: its ``convert_Digital_input_image`` + ``convert_Analogue_input_image``
    (the live image cut into 4 bit-planes and rebuilt, every frame). ``replicate``
    (lowres): ``scamp5_scan_areg_mean_8x8`` and ``load_analog_image``, 64 masked DAC loads
    with the mask moved by ``scamp5_shift``. ``compare``: ``absolute_differences`` (SAD,
    the in-block sum ``sum_analog_reg`` over 8x8 blocks, the masked update); lbp: the XOR
    plane made analogue and summed over 4x8 blocks the same way (extrapolated). ``shift``
    (forward frames): ``move_forward``. ``detect``: :func:`precursor_detect_counts`.
    """
    if representation not in REPLACED_STAGES:
        raise PpalocError(f"representation={representation!r}: use 'lowres' or 'lbp'")
    stages: dict[str, dict[str, float]] = {}
    digitise = _program(
        ["digitise", "mov_dreg", "where_sub_all", "refresh4"], [("scamp5_in", 0)] * 2
    )
    rebuild = _program(["all", "where_add_all"], [("scamp5_in", 0)])
    stages["requantise"] = add_counts(
        *([digitise] * BIT_PLANES), _program(["all"], [("scamp5_in", 0)]), *([rebuild] * 4)
    )
    if representation == "lowres":
        per_pixel = _program(["where_r5", "all"], [("load_in", 0), ("shift_dreg", 1)])
        rows = [_program([], [("load_pattern", 0), ("shift_dreg", j)]) for j in range(8)]
        stages["replicate"] = add_counts(
            _calls(("scan_areg_mean_8x8", 0)),
            kernel_counts("res_set_all"),
            *rows,
            {k: 64 * v for k, v in per_pixel.items()},
        )
        head = _program(["sub_abs_clr"])
        block_sum = _in_block_sum((4, 2, 1), (4, 2, 1))
    else:
        head = _program(["xor_to_areg"], [("load_in", 0)])
        block_sum = _in_block_sum((4, 2, 1), (2, 1))
    stages["compare"] = add_counts(
        head, block_sum, _program(["all", "where_sub_add"], [("load_rect", 0), ("load_in", 0)])
    )
    if forward:
        stages["shift"] = _program(
            [
                "all_clr3",
                "mov",
                *("where_mov", "where_mov", "where_mov_all"),
                *("where_mov", "where_mov_all", "where_mov", "where_mov"),
            ],
            [("scamp5_in", 0)] * 3
            + [("load_pattern", 0)] * 3
            + [("load_rect", 0)]
            + [("shift_areg", 8)] * 4
            + [("shift_dreg", 8)] * 4
            + [("shift_dreg", 248)],
        )
    stages["detect"] = precursor_detect_counts(weights)
    return stages


def structure_counts(
    stage_counts: Mapping[str, Mapping[str, float]],
    representation: str,
    structure: str = "ppaloc",
    *,
    forward: bool = True,
    weights: np.ndarray | None = None,
) -> dict[str, float]:
    """One frame's ``chip`` counts under a program structure.

    ``stage_counts`` is the frame's per-stage counts from the simulator
    (:func:`ppaloc.sim.timing.diff_counts`); ``"ppaloc"`` sums them, ``"precursor"``
    replaces :data:`REPLACED_STAGES` by :func:`precursor_stage_counts`.
    """
    if structure not in STRUCTURES:
        raise PpalocError(f"structure={structure!r} is not one of {', '.join(STRUCTURES)}")
    if structure == "ppaloc":
        return add_counts(*stage_counts.values())
    replaced = REPLACED_STAGES[representation]
    kept = [c for s, c in stage_counts.items() if s not in replaced]
    ours = precursor_stage_counts(representation, forward=forward, weights=weights)
    return add_counts(*kept, *ours.values())


def injection_counts(
    frame: np.ndarray, bit_planes: int = BIT_PLANES, injection: str = "drawn"
) -> dict[str, float]:
    """The host's frame injected as the precursor does it (``load_image_input_register``).

    One ``vs_gui_request_image`` of ``bit_planes`` planes (256 x 32 bytes each, the top
    bits of the frame); each plane cleared and drawn into a DREG by ``load_dreg_image``:
    one ``scamp5_draw_rect`` per run of 0xFF bytes in a row, one ``scamp5_draw_pixel``
    per set bit of the other non-zero bytes, a refresh of the planes every 16 rows; then
    the analogue image rebuilt with one DAC load and one masked add per plane. The draw
    counts depend on the frame's content (a natural image: tens of thousands of pixels).

    ``injection="bytes"`` keeps only the request and the planes' bytes (no drawing, no
    rebuild): what injection costs at the least, whatever path writes the planes.
    """
    if injection not in INJECTIONS:
        raise PpalocError(f"injection={injection!r} is not one of {', '.join(INJECTIONS)}")
    img = np.asarray(frame)
    if img.dtype != np.uint8 or img.ndim != 2 or img.shape[1] % 8:
        raise PpalocError(
            f"a sensor frame must be 2-D uint8 with a multiple of 8 columns (256 x 256 on "
            f"SCAMP-5), got {img.dtype} {img.shape}"
        )
    rows, cols = img.shape
    if injection == "bytes":
        return _calls(("vs_gui_request_image", bit_planes * rows * cols // 8))
    counts = dict(_drawn_injection(bit_planes, rows, cols))
    rects, pixels = _draws(img, bit_planes)
    counts["calls:scamp5_draw_rect"] = float(rects)
    counts["calls:scamp5_draw_pixel"] = float(pixels)
    return counts


@cache
def _drawn_injection(bit_planes: int, rows: int, cols: int) -> dict[str, float]:
    """:func:`injection_counts` of a drawn frame with no draws: what does not depend on the
    frame's content, made once per frame size (the draw counts keep their places)."""
    refresh = kernel_counts("refresh4")
    draw = add_counts(
        _calls(("vs_gui_request_image", bit_planes * rows * cols // 8)),
        {k: bit_planes * v for k, v in kernel_counts("clr").items()},
        {k: bit_planes * -(-rows // 16) * v for k, v in refresh.items()},
    )
    draw["calls:scamp5_draw_rect"] = 0.0
    draw["calls:scamp5_draw_pixel"] = 0.0
    rebuild = _program(["where_add_all", "refresh4"], [("scamp5_in", 0)])
    return add_counts(
        draw, _calls(("scamp5_in", 0)), {k: bit_planes * v for k, v in rebuild.items()}
    )


def _draws(img: np.ndarray, bit_planes: int) -> tuple[int, int]:
    """``(draw_rect calls, draw_pixel calls)`` of the top ``bit_planes`` planes of ``img``.

    A plane's byte is 8 pixels of a row, so each 64-bit word of the frame holds one byte
    of every plane: ANDing its 8 bytes gives the planes in which that byte is 0xFF. A run
    of full bytes is one rect; the other bytes' set bits are pixels. Both are totals over
    the planes, so they are bit counts under a mask of the planes' bits (no per-plane
    pass).
    """
    top = (0xFF00 >> min(max(bit_planes, 0), 8)) & 0xFF  # the bits of the planes drawn
    words = np.ascontiguousarray(img).view(np.uint64)
    all8 = words & (words >> np.uint64(32))
    all8 &= all8 >> np.uint64(16)
    all8 &= all8 >> np.uint64(8)
    full = all8.astype(np.uint8) & np.uint8(top)  # per byte: the planes it is 0xFF in
    n_full = _bits_set(full)
    rects = n_full - _bits_set(full[:, 1:] & full[:, :-1])  # runs of full bytes
    pixels = _bits_set(words & np.uint64(top * 0x0101010101010101)) - 8 * n_full
    return rects, pixels


def _bits_set(a: np.ndarray) -> int:
    return int(np.bitwise_count(a).sum())


def loop_counts(
    frame: np.ndarray, output_bytes: int = 4, injection: str = "drawn"
) -> dict[str, float]:
    """What the ``loop`` boundary adds to ``chip`` for one frame.

    ``vs_frame_loop_control``, the frame's injection (:func:`injection_counts`) and one
    message with the estimate (node and score, ``output_bytes``) to the host. No display
    images (the precursor sends seven per frame when its GUI is on; a timed run would not).
    """
    return add_counts(
        _calls(("vs_frame_loop_control", 0), ("usb_output", output_bytes)),
        injection_counts(frame, injection=injection),
    )
