"""What every number in the report's tables is: one definition per column, with its unit
and whether it depends on the recall definition.

The report's definitions section and the printed table's notes are made from
:data:`COLUMNS`, and a test checks that every header of every table has an entry here and
a row in docs/evaluate-cli.md, so a new column cannot appear undefined.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from ppaloc.evaluate.metrics import RECALL_DEFINITIONS

__all__ = ["COLUMNS", "TERMS", "Column", "column_of"]


@dataclass(frozen=True)
class Column:
    """The definition of one table column.

    Attributes
    ----------
    header : str
        The header as the report's tables write it (a Table I column stands for every
        representation: ``"F1 (representation)"``).
    field : str
        Where ``results.json`` keeps it (``methods.NAME.<field>``), or ``""``.
    unit : str
        The unit of its values.
    definition : str
        What it is and over which queries.
    recall : bool
        Whether its value depends on the recall definition (A, B or C) of the run.
    """

    header: str
    field: str
    unit: str
    definition: str
    recall: bool = False


_FRACTION = "fraction, 0-1"

TERMS: tuple[tuple[str, str], ...] = (
    (
        "Correct",
        "a query whose predicted reference frame is one of its accepted frames (the "
        "dataset's ground truth, its tolerance applied); a query with no true match is "
        "never correct",
    ),
    (
        "Accepted",
        "a query whose confidence is at least the threshold; a PR curve has one "
        "threshold per distinct confidence value",
    ),
    ("Precision", "correct accepted / accepted"),
    *((f"Recall {k}", v) for k, v in RECALL_DEFINITIONS.items()),
    (
        "Recall@K",
        "queries with a true match whose K best candidates (the method's ranking, as "
        "reference frames) include a correct one / queries with a true match; every query "
        "counts whatever its confidence, so it has no threshold and no A/B/C variant; '-' "
        "where the method ranks fewer than K candidates a query (the on-sensor pipelines "
        "rank none)",
    ),
)
"""The words the column definitions use, defined once."""

COLUMNS: tuple[Column, ...] = (
    Column(
        "Method",
        "",
        "-",
        "the registered method; a -paper- name is the paper's Algorithm 1 preset of the weighted-"
        "node filter",
    ),
    Column("Representation", "map_kind", "-", "the place representation of the method's map nodes"),
    Column(
        "F1 max", "f1_max", _FRACTION, "the highest F1 = 2PR/(P+R) over the PR curve", recall=True
    ),
    Column(
        "F1 straight",
        "f1_max_straight",
        _FRACTION,
        "F1 max of the PR curve of the queries taken on straight stretches alone (the dataset's "
        "query_turning)",
        recall=True,
    ),
    Column(
        "F1 turning",
        "f1_max_turning",
        _FRACTION,
        "F1 max of the PR curve of the queries taken in turns alone",
        recall=True,
    ),
    Column("P @F1", "precision_at_f1", _FRACTION, "precision at the max-F1 point", recall=True),
    Column("R @F1", "recall_at_f1", _FRACTION, "recall at the max-F1 point", recall=True),
    Column(
        "AUC",
        "auc",
        _FRACTION,
        "area under the PR curve by the trapezoid rule, from recall 0 (at the most confident "
        "point's precision) to the last point",
        recall=True,
    ),
    Column(
        "R @100%P",
        "recall_at_100p",
        _FRACTION,
        "the highest recall at a threshold where every accepted query is correct (0 if none)",
        recall=True,
    ),
    Column(
        "P @100%R",
        "precision_at_100r",
        _FRACTION,
        "precision with every query accepted (the PR curve's last point) = queries whose best "
        "match is correct / all queries, a query without a true match counting as wrong and a "
        "soft prediction counting nowhere; accepting "
        "every query is 100% recall under recall B and C, while under A that point's recall is "
        "correct / queries with a true match (1 only when every one is right); the value is the "
        "same under every definition (results written before format 2 called it accuracy)",
    ),
    Column(
        "Host ms/frame (median)",
        "latency_ms_median",
        "ms",
        "median wall-clock time of one step on this machine over every query frame, all methods in "
        "one process and run",
    ),
    Column("Host ms (p95)", "latency_ms_p95", "ms", "95th percentile of the same"),
    Column(
        "Modelled chip ms/frame (low-high)",
        "modelled_time_ms.chip",
        "ms",
        "median modelled time per frame of the simulated sensor's kernels and controller calls, "
        "the timing model's middle estimate with its low-high interval (docs/onsensor.md, Timing); "
        "on-sensor methods only",
    ),
    Column(
        "Modelled loop ms/frame (low-high)",
        "modelled_time_ms.loop",
        "ms",
        "the same for the whole hardware loop: the chip plus the host's frame injection, loop "
        "control and output",
    ),
    Column(
        "Energy mJ/frame",
        "energy_mj",
        "mJ",
        "mean modelled energy per frame of a simulated sensor (energy per PE-ICW and system "
        "power); on-sensor methods only",
    ),
    Column(
        "Recall@1",
        "recall_at_k.1",
        _FRACTION,
        "as Recall@K with K = 1: queries with a true match whose best candidate is correct / "
        "queries with a true match",
    ),
    Column("Recall@5", "recall_at_k.5", _FRACTION, "Recall@K with K = 5"),
    Column("Recall@10", "recall_at_k.10", _FRACTION, "Recall@K with K = 10"),
    Column(
        "Median error (frames)",
        "error_frames_median",
        "reference frames",
        "per query with a true match, the distance from the predicted reference frame to the "
        "nearest accepted (hard) one (0 when correct); the median over those queries, every "
        "estimate counted (no threshold)",
    ),
    Column(
        "Median error (m)",
        "error_m_median",
        "metres",
        "per query with a true match, the distance from the predicted reference frame's position "
        "to the query's own; the median over those queries (no threshold); only where the dataset "
        "has positions",
    ),
    Column(
        "Motion accuracy",
        "motion_accuracy",
        _FRACTION,
        "query frames where the method's forward/stay decision equals the dataset's true motion "
        "(query_moved) / all query frames; only where both exist",
    ),
    Column(
        "Nodes",
        "n_nodes",
        "nodes",
        "nodes in the method's map (a keyframe map merges a stop into one node, so it may have "
        "fewer nodes than reference frames)",
    ),
    Column(
        "Map build (s)",
        "build_s",
        "s",
        "host wall-clock time of build_map, including reading and converting the reference frames "
        "it is the first to read (on a route short enough for the methods to share its converted "
        "frames, the first method reads them for all); a simulated sensor's first run on a "
        "machine also compiles the simulator's code, which is cached for the next runs "
        "(`ppaloc warm-up` compiles it ahead)",
    ),
    Column(
        "F1 (representation)",
        "f1_max",
        _FRACTION,
        "Table I: F1 max of the family's method with that place representation",
        recall=True,
    ),
    Column(
        "ms/frame host | chip | loop (representation)",
        "",
        "ms",
        "Table I: Host ms/frame (median) | Modelled chip ms/frame | Modelled loop ms/frame of that "
        "method, each as in its own column",
    ),
)
"""Every column of the report's tables, in the order the definitions list them."""

_BY_HEADER = {c.header: c for c in COLUMNS}
_REPRESENTATION = re.compile(
    r"^(.*) \((8x8 image|16x16 image|32-bit LBP|192 Haar signs|64x32 patch-normalised|"
    r"method's own)\)$"
)
"""A Table I header: a field and the representation column it is shown in."""


def column_of(header: str) -> Column | None:
    """The definition of a table header (a Table I header by its representation-free form).

    Examples
    --------
    >>> column_of("P @100%R").field, column_of("F1 (32-bit LBP)").header
    ('precision_at_100r', 'F1 (representation)')
    >>> column_of("Accuracy") is None
    True
    """
    if header in _BY_HEADER:
        return _BY_HEADER[header]
    match = _REPRESENTATION.match(header)
    if match:
        return _BY_HEADER.get(f"{match.group(1)} (representation)")
    return None
