"""``synthetic:?places=500&query=winter&seed=1``: the procedural route generator as a spec."""

from __future__ import annotations

from ppaloc.datasets.route import RawRoute
from ppaloc.datasets.spec import DatasetSpec, Key, KindSchema
from ppaloc.datasets.synthetic.conditions import CONDITIONS
from ppaloc.datasets.synthetic.generate import (
    MAX_OFFSET,
    MAX_PLACES,
    MAX_SEED,
    MAX_SIZE,
    MAX_SPACING,
    MAX_SPEED,
    WORLDS,
    synthetic_route,
)
from ppaloc.datasets.synthetic.lab import LAB_CONDITIONS
from ppaloc.datasets.synthetic.motion import SPEED_VAR

__all__ = ["SCHEMA", "load"]

_NAMES = (*CONDITIONS, *LAB_CONDITIONS)
SCHEMA = KindSchema(
    n_paths=(0,),
    keys={
        "places": Key("int", 500, "reference frames (one per place)", 2, maximum=MAX_PLACES),
        "world": Key("choice", "road", "road or lab", choices=WORLDS),
        "turns": Key(
            "int", None, "turns of the route, 0..places//4 (road default 0)", 0,
            maximum=MAX_PLACES // 4,
        ),
        "ref": Key("choice", "summer", "reference condition (lab: lab)", choices=_NAMES),
        "query": Key("choice", "winter", "query condition (lab: changed)", choices=_NAMES),
        "seed": Key("int", 0, "world, motion and noise seed", 0, maximum=MAX_SEED),
        "sync": Key("bool", False, "one query frame per place"),
        "spacing": Key(
            "float", 4.0, "metres between places (lab: 0.5)", 0.5, maximum=MAX_SPACING
        ),
        "speed": Key(
            "float", 1.0, "mean query speed, places per frame", 0.05, maximum=MAX_SPEED
        ),
        "speed_var": Key(
            "float", SPEED_VAR, "peak relative query speed variation (0.65: the wide profile)",
            0.0, maximum=0.9,
        ),
        "stops": Key(
            "int", None, "query stops (default: one per 150 places), at most places", 0,
            maximum=MAX_PLACES,
        ),
        "extra": Key(
            "int", 0, "places the query drives past the end of the map, at most places", 0,
            maximum=MAX_PLACES,
        ),
        "offset": Key(
            "float", None, "query lateral offset in metres", -MAX_OFFSET, maximum=MAX_OFFSET
        ),
        "size": Key("int", 256, "frame side in pixels", 16, maximum=MAX_SIZE),
    },
    example="synthetic:?places=500&query=winter&seed=1",
)  # fmt: skip


def load(spec: DatasetSpec) -> RawRoute:
    """Generate the route a ``synthetic`` spec describes (frames render on access)."""
    options = {name: spec.options[name] for name in SCHEMA.keys}
    if options["world"] != "road":  # the road's defaults do not apply indoors
        for name in ("ref", "query", "spacing"):
            if name not in spec.given:
                options[name] = None
    return synthetic_route(**options)
