"""``vprbench:DIR``: the VPR-Bench layout, ``ref/`` and ``query/`` plus ``ground_truth_new.npy``.

The ground-truth file holds rows ``[query_index, [accepted reference indices]]`` as a
pickled numpy object array. It is read by an unpickler that can only rebuild numpy arrays,
lists and numbers (see :func:`ppaloc.datasets.groundtruth.read_vprbench`); ``trust=1``
allows full unpickling, which runs whatever code the file carries: only for trusted files.
The accepted sets already include VPR-Bench's tolerance, so the default here is 0.
"""

from __future__ import annotations

from ppaloc.datasets.frames import ImageFrames
from ppaloc.datasets.groundtruth import read_vprbench
from ppaloc.datasets.images import list_images, require_dir
from ppaloc.datasets.route import RawRoute
from ppaloc.datasets.spec import DatasetSpec, Key, KindSchema

__all__ = ["SCHEMA", "load"]

SCHEMA = KindSchema(
    n_paths=(1,),
    keys={
        "gt": Key("str", "ground_truth_new.npy", "ground-truth file inside DIR"),
        "trust": Key("bool", False, "allow full unpickling of the ground-truth file"),
    },
    example="vprbench:data/GardensPoint",
)


def load(spec: DatasetSpec) -> RawRoute:
    """Load ``DIR/ref``, ``DIR/query`` and the accepted sets from ``DIR/<gt>``."""
    root = require_dir(spec.paths[0], "VPR-Bench folder")
    ref = ImageFrames(list_images(root / "ref", "VPR-Bench reference folder"))
    query = ImageFrames(list_images(root / "query", "VPR-Bench query folder"))
    accepted = read_vprbench(root / spec.options["gt"], len(query), len(ref), spec.options["trust"])
    return RawRoute(
        name=f"vprbench {root.name}",
        reference=ref,
        query=query,
        default_tolerance=0,
        accepted=accepted,
        meta={"kind": "vprbench", "root": str(root)},
    )
