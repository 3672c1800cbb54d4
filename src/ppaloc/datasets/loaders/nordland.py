"""``nordland:DIR``: the Nordland railway dataset in the OpenSeqSLAM layout.

``DIR`` holds season folders (``spring``, ``summer``, ``fall``, ``winter``) of
``images-NNNNN.png``; the same file name is the same place in every season (frame-
synchronised). About 6% of the frames are tunnels (near-black); ``drop_dark=1`` removes a
frame index from *both* traversals when either frame's mean grey is below ``dark``, so the
two stay synchronised. Tolerance in the literature: +-1 to +-2 frames.
"""

from __future__ import annotations

import numpy as np

from ppaloc.datasets.frames import ImageFrames
from ppaloc.datasets.images import list_images, read_grey, require_dir
from ppaloc.datasets.route import RawRoute
from ppaloc.datasets.spec import DatasetSpec, Key, KindSchema
from ppaloc.errors import DataError

__all__ = ["SCHEMA", "SEASONS", "dark_frames", "load"]

SEASONS = ("spring", "summer", "fall", "winter")
SCHEMA = KindSchema(
    n_paths=(1,),
    keys={
        "ref": Key("choice", "summer", "reference season", choices=(*SEASONS, "autumn")),
        "query": Key("choice", "winter", "query season", choices=(*SEASONS, "autumn")),
        "drop_dark": Key("bool", False, "drop tunnel frames from both traversals together"),
        "dark": Key(
            "float", 30.0, "mean grey (0-255) below which a frame is dark", 0.0, maximum=255.0
        ),
    },
    example="nordland:data/nordland-64x32?ref=summer&query=winter&drop_dark=1",
)
DEFAULT_TOLERANCE = 1


def dark_frames(frames: ImageFrames, threshold: float) -> np.ndarray:
    """Boolean mask, shape (len(frames),): mean grey below ``threshold`` (reads every frame)."""
    return np.array([float(read_grey(p).mean()) < threshold for p in frames.paths], bool)


def _season_dir(root, season: str):
    name = "fall" if season == "autumn" else season
    d = root / name
    if not d.is_dir():
        present = sorted(p.name for p in root.iterdir() if p.is_dir())
        if not present and root.name in (*SEASONS, "autumn"):  # a season given as the root
            raise DataError(
                f"Nordland folder {root} is a season folder, not the folder that holds the "
                f"seasons: give its parent ({root.parent}) and choose the seasons with ref= "
                "and query="
            )
        raise DataError(
            f"Nordland season folder {d} does not exist (present: {', '.join(present) or 'none'}); "
            "choose ref= and query= among them"
        )
    return d


def load(spec: DatasetSpec) -> RawRoute:
    """Load two Nordland seasons, synchronised by file name."""
    root = require_dir(spec.paths[0], "Nordland folder")
    o = spec.options
    if o["ref"] == o["query"]:
        raise DataError(f"ref and query are both {o['ref']!r}: choose two different seasons")
    dirs = [_season_dir(root, o["ref"]), _season_dir(root, o["query"])]
    ref_files = list_images(dirs[0], "reference season folder")
    query_files = list_images(dirs[1], "query season folder")
    ref_names = [p.name for p in ref_files]
    query_names = [p.name for p in query_files]
    if ref_names != query_names:
        only = sorted(set(ref_names) ^ set(query_names))
        where = dirs[0] if only and only[0] in set(ref_names) else dirs[1]
        raise DataError(
            f"Nordland seasons {dirs[0]} and {dirs[1]} hold different frames (e.g. "
            f"{where / only[0] if only else 'the order differs'} has no partner): ground truth "
            "is by file name, so both folders need the same file names"
        )
    ref, query = ImageFrames(ref_files), ImageFrames(query_files)
    keep = np.arange(len(ref))
    meta = {
        "kind": "nordland",
        "root": str(root),
        "ref": o["ref"],
        "query": o["query"],
        "roles": {
            "database": f"Nordland {o['ref']} journey ({dirs[0].name}/)",
            "query": f"Nordland {o['query']} journey ({dirs[1].name}/)",
        },
    }
    if o["drop_dark"]:
        dark = dark_frames(ref, o["dark"]) | dark_frames(query, o["dark"])
        keep = np.flatnonzero(~dark)
        meta["dropped_dark"] = int(dark.sum())
        if keep.size == 0:
            raise DataError(f"every frame is darker than dark={o['dark']:g}: lower the threshold")
        ref, query = ref.select(keep), query.select(keep)
    meta["file_index"] = keep
    return RawRoute(
        name=f"nordland {o['ref']}->{o['query']}",
        reference=ref,
        query=query,
        default_tolerance=DEFAULT_TOLERANCE,
        query_place=np.arange(len(query), dtype=np.float64),
        meta=meta,
        truth={"source": "file name (frame-synchronised seasons)"},
    )
