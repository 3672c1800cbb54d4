"""A user's own ground truth for ``folder:`` and ``video:``: positions files or matrices.

Without these keys, frame ``i`` of the query is the same place as frame ``i`` of the
reference (``video:`` may also align proportionally). With them:

- ``ref_positions=R.csv&query_positions=Q.csv&tolerance_m=T``: each query accepts the
  reference frames within ``T`` metres (:mod:`ppaloc.datasets.positions`);
  ``soft_tolerance_m=S`` (``S >= T``) adds soft sets; same-place groups come from the
  reference positions (``same_place_m``, default 1 m).
- ``gt=H.npy|.npz|.csv`` (queries x references, ``gt_transpose=1`` for references x
  queries), ``gt_soft=S...``: hard and soft matrices (:mod:`ppaloc.datasets.gtmatrix`),
  the file's word: not closed over same-place groups unless ``same_place=`` asks. Positions
  given beside a matrix only give the error in metres (and ``same_place=positions``).

The two traversals may then differ in length. Every combination is checked before a file
is read, and every file before a frame is.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ppaloc.datasets.gtmatrix import read_matrix
from ppaloc.datasets.positions import read_positions, to_metres
from ppaloc.datasets.route import RawRoute
from ppaloc.datasets.spec import DatasetSpec, Key, _show
from ppaloc.errors import DataError, DatasetSpecError

__all__ = ["KEYS", "MAX_TOLERANCE_M", "apply", "check", "given"]

MAX_TOLERANCE_M = 100_000.0
"""Largest ``tolerance_m`` and ``soft_tolerance_m`` (100 km; the accepted pairs are bounded
too, :data:`ppaloc.datasets.groundtruth.MAX_GROUND_TRUTH_ITEMS`)."""

KEYS: dict[str, Key] = {
    "ref_positions": Key(
        "str", None, "positions CSV of the reference frames (x,y / easting,northing / lat,lon)"
    ),
    "query_positions": Key("str", None, "positions CSV of the query frames"),
    "tolerance_m": Key(
        "float", None, "accepted distance in metres (with positions)", 0.0,
        maximum=MAX_TOLERANCE_M,
    ),
    "soft_tolerance_m": Key(
        "float", None, "soft ground truth: also not wrong within this many metres",
        0.0, maximum=MAX_TOLERANCE_M,
    ),
    "same_place_m": Key(
        "float", None, "radius of a same-place group from positions, metres (default 1)",
        0.0, maximum=1000.0,
    ),
    "gt": Key("str", None, "hard ground-truth matrix, queries x references (.npy .npz .csv)"),
    "gt_soft": Key("str", None, "soft ground-truth matrix (also not wrong), same shape"),
    "gt_transpose": Key("bool", False, "the matrices are references x queries (VPR_Tutorial)"),
}  # fmt: skip
"""The keys ``folder`` and ``video`` accept for a user's own ground truth."""


def given(spec: DatasetSpec) -> bool:
    """Whether the spec gives its own ground truth (positions or a matrix)."""
    o = spec.options
    return o.get("gt") is not None or o.get("ref_positions") is not None


def check(spec: DatasetSpec) -> None:
    """Refuse a combination of keys that cannot mean one ground truth (before any file is
    read).

    Raises
    ------
    DatasetSpecError
        Naming the keys and the fix.
    """
    o = spec.options
    has = {k for k in KEYS if k != "gt_transpose" and o.get(k) is not None}
    if o.get("gt_transpose"):
        has.add("gt_transpose")
    positions = {"ref_positions", "query_positions"} & has
    text = spec.text

    def fail(why: str) -> DatasetSpecError:
        return DatasetSpecError(f"dataset spec {_show(text, 120)}: {why}")

    if len(positions) == 1:
        other = ({"ref_positions", "query_positions"} - positions).pop()
        raise fail(f"{positions.pop()} needs {other} too: give both traversals' positions")
    if "gt_soft" in has and "gt" not in has:
        raise fail("gt_soft needs gt (the hard matrix) too")
    if "gt_transpose" in has and "gt" not in has:
        raise fail("gt_transpose applies to gt= and gt_soft=; give gt=")
    for key in ("tolerance_m", "soft_tolerance_m", "same_place_m"):
        if key in has and not positions:
            raise fail(
                f"{key} is a distance between positions: add ref_positions= and query_positions="
            )
    if "gt" in has:
        for key in ("tolerance_m", "soft_tolerance_m"):
            if key in has:
                raise fail(f"gt= gives the ground truth, {key} applies to positions: drop one")
        if "gt_soft" in has and o.get("soft_tolerance") is not None:
            raise fail("gt_soft and soft_tolerance both give soft ground truth: drop one")
    elif positions:
        if "tolerance_m" not in has:
            raise fail(
                "positions give the ground truth in metres: add tolerance_m= (e.g. tolerance_m=25)"
            )
        for key in ("tolerance", "soft_tolerance"):
            if o.get(key) is not None:
                raise fail(
                    f"mixed units: {key} counts frames but the ground truth is in metres "
                    f"(tolerance_m): drop {key}"
                )
        soft = o.get("soft_tolerance_m")
        if soft is not None and soft < o["tolerance_m"]:
            raise fail(
                f"soft_tolerance_m={soft:g} is below tolerance_m={o['tolerance_m']:g}; a soft "
                "set holds its hard set and more: give soft_tolerance_m >= tolerance_m"
            )
    if given(spec) and "align" in spec.given:
        raise fail(
            "align applies to ground truth by frame index; drop it (gt= or positions give it)"
        )


def apply(
    raw: RawRoute,
    spec: DatasetSpec,
    reference_names: Sequence[str] | None = None,
    query_names: Sequence[str] | None = None,
) -> RawRoute:
    """Put the spec's own ground truth into ``raw`` (a loader's by-index route).

    Parameters
    ----------
    raw : RawRoute
        The traversals; its ``query_place`` (by index) is replaced.
    spec : DatasetSpec
        Checked by :func:`check`.
    reference_names, query_names : sequence of str, optional
        Each frame's file name, to check a positions file's name column against.

    Returns
    -------
    RawRoute
        ``raw`` itself, changed.
    """
    o = spec.options
    n_ref, n_query = len(raw.reference), len(raw.query)
    files: dict[str, Any] = {}
    if o.get("ref_positions") is not None:
        ref = read_positions(o["ref_positions"], n_ref, "ref_positions", reference_names)
        qry = read_positions(o["query_positions"], n_query, "query_positions", query_names)
        raw.reference_positions, raw.query_positions = to_metres(ref, qry)
        for key, f in (("ref_positions", ref), ("query_positions", qry)):
            files[key] = {"name": f.path.name, "sha256": f.sha256}
        raw.truth["positions"] = {"units": ref.units, "columns": list(ref.columns)}
        if ref.kind == "latlon":
            raw.truth["positions"]["metres"] = "WGS84 east, north, up at the first reference frame"
    if o.get("gt") is not None:
        hard = read_matrix(o["gt"], n_query, n_ref, "gt", transpose=o["gt_transpose"])
        files["gt"] = {"name": hard.path.name, "sha256": hard.sha256}
        soft = hard.soft
        if o.get("gt_soft") is not None:
            loose = read_matrix(
                o["gt_soft"], n_query, n_ref, "gt_soft", transpose=o["gt_transpose"]
            )
            files["gt_soft"] = {"name": loose.path.name, "sha256": loose.sha256}
            soft = loose.sets
        if soft is not None:
            _require_superset(hard.sets, soft, o["gt_soft"] or o["gt"])
        raw.query_place = None
        raw.accepted = list(hard.sets)
        raw.accepted_soft = None if soft is None else list(soft)
        raw.truth.update(source="matrix", matrix=True)
        if o["gt_transpose"]:
            raw.truth["layout"] = "references x queries"
    elif o.get("ref_positions") is not None:
        raw.query_place = None
        raw.metres = True
        raw.truth["source"] = "positions"
    raw.truth["files"] = files
    raw.motion_known = False
    return raw


def _require_superset(hard: Sequence[np.ndarray], soft: Sequence[np.ndarray], name: str) -> None:
    """Every hard match must be soft too; a soft matrix missing some suggests two files
    swapped."""
    for q, (h, s) in enumerate(zip(hard, soft, strict=True)):
        missing = np.setdiff1d(h, s)
        if missing.size:
            raise DataError(
                f"the soft ground truth {name} lacks the hard match (query {q}, reference "
                f"{int(missing[0])}); a soft matrix holds every hard match and more: are gt "
                "and gt_soft swapped?"
            )
