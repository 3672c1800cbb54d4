"""``folder:REF_DIR,QUERY_DIR``: two folders of images.

Ground truth by index (frame ``i`` of both is the same place), or the user's own:
positions files with a tolerance in metres, or hard and soft matrices
(:mod:`ppaloc.datasets.loaders.owntruth`).
"""

from __future__ import annotations

import numpy as np

from ppaloc.datasets.frames import ImageFrames
from ppaloc.datasets.images import list_images
from ppaloc.datasets.loaders import owntruth
from ppaloc.datasets.route import RawRoute
from ppaloc.datasets.spec import DatasetSpec, KindSchema
from ppaloc.errors import DataError

__all__ = ["SCHEMA", "load", "require_equal_length"]

SCHEMA = KindSchema(
    n_paths=(2,),
    keys=dict(owntruth.KEYS),
    example="folder:ref_frames,query_frames?tolerance=1",
)
DEFAULT_TOLERANCE = 0


def require_equal_length(ref: ImageFrames, query: ImageFrames, ref_dir, query_dir) -> None:
    """Raise a ``DataError`` when frame-synchronised folders differ in length."""
    if len(ref) != len(query):
        raise DataError(
            f"reference {ref_dir} has {len(ref)} images but query {query_dir} has "
            f"{len(query)}; ground truth by index needs the same number in both: "
            "remove the extra frames or select a common range with start=/stop="
        )


def load(spec: DatasetSpec) -> RawRoute:
    """Load two image folders and their ground truth.

    Images are naturally sorted (``Image2`` before ``Image10``). By index, query frame
    ``i`` is the same place as reference frame ``i`` and both folders must hold the same
    number of images; with positions or a matrix they may differ.
    """
    owntruth.check(spec)
    ref_dir, query_dir = spec.paths
    ref = ImageFrames(list_images(ref_dir, "reference folder"))
    query = ImageFrames(list_images(query_dir, "query folder"))
    own = owntruth.given(spec)
    if not own:
        require_equal_length(ref, query, ref_dir, query_dir)
    raw = RawRoute(
        name=f"folder {ref_dir.name}->{query_dir.name}",
        reference=ref,
        query=query,
        default_tolerance=DEFAULT_TOLERANCE,
        query_place=np.arange(len(query), dtype=np.float64),
        meta={
            "kind": "folder",
            "reference_dir": str(ref_dir),
            "query_dir": str(query_dir),
            "roles": {"database": f"images in {ref_dir}", "query": f"images in {query_dir}"},
        },
        truth={"source": "index"},
    )
    if own:
        names = [p.name for p in ref.paths], [p.name for p in query.paths]
        owntruth.apply(raw, spec, *names)
    return raw
