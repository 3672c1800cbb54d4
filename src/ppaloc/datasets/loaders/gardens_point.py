"""``gardens-point:DIR``: Gardens Point Walking (``day_left``, ``day_right``, ``night_right``).

Three hand-held traversals of the QUT campus, 200 frames each; the same index is the same
place in all three (Glover 2014, doi:10.5281/zenodo.4590133). The usual tolerance is +-2
frames. ``gt=vprbench`` reads ``vprbench_ground_truth.npy`` (VPR-Bench's +-2 rows) instead.
"""

from __future__ import annotations

import numpy as np

from ppaloc.datasets.frames import ImageFrames
from ppaloc.datasets.groundtruth import file_digest, read_vprbench
from ppaloc.datasets.images import list_images, require_dir
from ppaloc.datasets.loaders.folder import require_equal_length
from ppaloc.datasets.route import RawRoute
from ppaloc.datasets.spec import DatasetSpec, Key, KindSchema
from ppaloc.errors import DataError

__all__ = ["SCHEMA", "TRAVERSALS", "load"]

TRAVERSALS = ("day_left", "day_right", "night_right")
SCHEMA = KindSchema(
    n_paths=(1,),
    keys={
        "ref": Key("choice", "day_right", "reference traversal", choices=TRAVERSALS),
        "query": Key("choice", "night_right", "query traversal", choices=TRAVERSALS),
        "gt": Key(
            "choice",
            "index",
            "ground truth: by index, or the VPR-Bench file",
            choices=("index", "vprbench"),
        ),
        "trust": Key("bool", False, "allow full unpickling of the VPR-Bench file"),
    },
    example="gardens-point:data/gardens-point?ref=day_left&query=night_right",
)
DEFAULT_TOLERANCE = 2
VPRBENCH_FILE = "vprbench_ground_truth.npy"


def load(spec: DatasetSpec) -> RawRoute:
    """Load two Gardens Point traversals, ground truth by index (or from the VPR-Bench file)."""
    root = require_dir(spec.paths[0], "Gardens Point folder")
    o = spec.options
    if o["ref"] == o["query"]:
        raise DataError(f"ref and query are both {o['ref']!r}: choose two different traversals")
    dirs = [root / o["ref"], root / o["query"]]
    for d in dirs:
        if not d.is_dir():
            raise DataError(
                f"Gardens Point traversal {d} does not exist: {root} should hold "
                f"{', '.join(TRAVERSALS)}"
            )
    ref = ImageFrames(list_images(dirs[0], "reference folder"))
    query = ImageFrames(list_images(dirs[1], "query folder"))
    require_equal_length(ref, query, dirs[0], dirs[1])
    raw = RawRoute(
        name=f"gardens-point {o['ref']}->{o['query']}",
        reference=ref,
        query=query,
        default_tolerance=DEFAULT_TOLERANCE,
        meta={
            "kind": "gardens-point",
            "root": str(root),
            "gt": o["gt"],
            "roles": {
                "database": f"Gardens Point {o['ref']} walk",
                "query": f"Gardens Point {o['query']} walk",
            },
        },
    )
    if o["gt"] == "vprbench":
        path = root / VPRBENCH_FILE
        raw.accepted = read_vprbench(path, len(query), len(ref), o["trust"])
        raw.default_tolerance = 0
        raw.truth = {"source": "VPR-Bench rows", "files": {"gt": file_digest(path)}}
    else:
        raw.query_place = np.arange(len(query), dtype=np.float64)
        raw.truth = {"source": "index (frame-synchronised walks)"}
    return raw
