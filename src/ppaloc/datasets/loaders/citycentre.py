"""``citycentre:DIR``: the Oxford City Centre (and New College) FAB-MAP layout.

The robot's camera looks alternately left and right: images are numbered in order of
capture, the first (odd-numbered when counting from 1) of each pair is the left view.
Ground truth is the square ``truth`` matrix of a ``.mat`` file (Cummins and Newman, IJRR
2008): entry ``(i, j)`` is 1 where images (or image pairs) ``i`` and ``j`` show the same place.
Its side is either the number of images or the number of pairs; both are read.

The route is one long drive that revisits places, so it is split in two: pairs before
``split`` are the reference (the map), pairs from ``split`` on are the query. By default
``split`` is the first pair that revisits a place seen at least ``MIN_LOOP`` pairs earlier.
Queries on streets the reference never saw have no true match.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ppaloc.datasets.frames import ImageFrames
from ppaloc.datasets.groundtruth import file_digest, read_truth_mat
from ppaloc.datasets.images import dataset_file, list_images, require_dir
from ppaloc.datasets.route import RawRoute
from ppaloc.datasets.spec import DatasetSpec, Key, KindSchema
from ppaloc.errors import DataError

__all__ = ["MIN_LOOP", "SCHEMA", "load", "pair_truth"]

MIN_LOOP = 20
"""A revisit must be at least this many pairs after the first visit to start the query."""

SCHEMA = KindSchema(
    n_paths=(1,),
    keys={
        "camera": Key("choice", "left", "which camera of each pair", choices=("left", "right")),
        "split": Key("int", None, "first pair of the query (default: first revisit)", 1),
        "truth": Key(
            "str",
            None,
            "ground-truth .mat file inside DIR (default: the only one; an absolute path: a "
            "file elsewhere)",
        ),
    },
    example="citycentre:data/CityCentre?camera=left",
)


def _find_truth(root: Path, name: str | None) -> Path:
    if name is not None:
        return dataset_file(root, name, "truth", ".mat")
    mats = sorted(root.glob("*.mat"))
    truthy = [p for p in mats if "truth" in p.name.lower()]
    found = truthy or mats
    if len(found) != 1:
        listed = ", ".join(p.name for p in found) or "none"
        raise DataError(
            f"cannot tell the ground-truth .mat file in {root} (found: {listed}); "
            "name it with truth=FILE.mat"
        )
    return found[0]


def pair_truth(truth: np.ndarray, n_images: int, camera: int, source: Path) -> np.ndarray:
    """Pair-by-pair truth for one camera (0 left, 1 right), symmetric, shape (P, P)."""
    pairs = n_images // 2
    side = truth.shape[0]
    if side == n_images:
        t = truth[camera::2, camera::2][:pairs, :pairs]
    elif side == pairs:
        t = truth
    else:
        raise DataError(
            f"{source}: the truth matrix is {side}x{side} but the folder has {n_images} images "
            f"({pairs} left/right pairs); it must match one of them"
        )
    return t | t.T


def load(spec: DatasetSpec) -> RawRoute:
    """Split one City Centre drive into a reference and a query traversal."""
    root = require_dir(spec.paths[0], "City Centre folder")
    images_dir = root / "Images" if (root / "Images").is_dir() else root
    files = list_images(images_dir, "City Centre image folder")
    if len(files) < 4 or len(files) % 2:
        raise DataError(
            f"{images_dir} holds {len(files)} images; the left/right layout needs an even "
            "number (two per capture)"
        )
    o = spec.options
    cam = 0 if o["camera"] == "left" else 1
    truth_path = _find_truth(root, o["truth"])
    truth = pair_truth(read_truth_mat(truth_path), len(files), cam, truth_path)
    pairs = truth.shape[0]
    split = o["split"]
    if split is None:
        lower = np.tril(truth, k=-MIN_LOOP)
        revisits = np.flatnonzero(lower.any(axis=1))
        if revisits.size == 0:
            raise DataError(
                f"{truth_path} marks no revisit {MIN_LOOP} or more pairs apart; give the "
                "first query pair with split=N"
            )
        split = int(revisits[0])
    if not 0 < split < pairs:
        raise DataError(f"split={split} must be between 1 and {pairs - 1} (pairs in {root})")
    own = files[cam::2]
    accepted = [np.flatnonzero(truth[q, :split]) for q in range(split, pairs)]
    return RawRoute(
        name=f"citycentre {root.name} ({o['camera']})",
        reference=ImageFrames(own[:split]),
        query=ImageFrames(own[split:pairs]),
        default_tolerance=0,
        accepted=accepted,
        meta={
            "kind": "citycentre",
            "root": str(root),
            "split": split,
            "truth": str(truth_path),
            "roles": {
                "database": f"{root.name}, {o['camera']} camera, pairs 0-{split - 1} (first pass)",
                "query": f"{root.name}, {o['camera']} camera, pairs {split}-{pairs - 1} (revisits)",
            },
        },
        truth={"source": "FAB-MAP truth matrix", "files": {"truth": file_digest(truth_path)}},
    )
