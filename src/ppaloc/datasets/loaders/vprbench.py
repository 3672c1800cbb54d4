"""``vprbench:DIR``: the VPR-Bench layout, ``ref/`` and ``query/`` plus ``ground_truth_new.npy``.

The ground-truth file holds rows ``[query_index, [accepted reference indices]]`` as a
pickled numpy object array. It is read by an unpickler that can only rebuild numpy arrays,
lists and numbers (see :func:`ppaloc.datasets.groundtruth.read_vprbench`); ``trust=1``
allows full unpickling, which runs whatever code the file carries: only for trusted files.
The accepted sets already include VPR-Bench's tolerance, so the default here is 0.
``gt=NAME`` is relative to DIR and must stay inside it; a file elsewhere is named by its
absolute path (:func:`ppaloc.datasets.images.dataset_file`).
"""

from __future__ import annotations

from ppaloc.datasets.frames import ImageFrames
from ppaloc.datasets.groundtruth import file_digest, read_vprbench
from ppaloc.datasets.images import dataset_file, list_images, require_dir
from ppaloc.datasets.route import RawRoute
from ppaloc.datasets.spec import DatasetSpec, Key, KindSchema

__all__ = ["SCHEMA", "load"]

SCHEMA = KindSchema(
    n_paths=(1,),
    keys={
        "gt": Key(
            "str",
            "ground_truth_new.npy",
            "ground-truth .npy file inside DIR (or an absolute path: a file elsewhere)",
        ),
        "trust": Key("bool", False, "allow full unpickling of the ground-truth file"),
    },
    example="vprbench:data/GardensPoint",
)


def load(spec: DatasetSpec) -> RawRoute:
    """Load ``DIR/ref``, ``DIR/query`` and the accepted sets from ``DIR/<gt>``."""
    root = require_dir(spec.paths[0], "VPR-Bench folder")
    ref = ImageFrames(list_images(root / "ref", "VPR-Bench reference folder"))
    query = ImageFrames(list_images(root / "query", "VPR-Bench query folder"))
    gt = dataset_file(root, spec.options["gt"], "gt", ".npy")
    accepted = read_vprbench(gt, len(query), len(ref), spec.options["trust"])
    return RawRoute(
        name=f"vprbench {root.name}",
        reference=ref,
        query=query,
        default_tolerance=0,
        accepted=accepted,
        meta={
            "kind": "vprbench",
            "root": str(root),
            "roles": {
                "database": f"VPR-Bench {root.name}/ref",
                "query": f"VPR-Bench {root.name}/query",
            },
        },
        truth={"source": "VPR-Bench rows", "files": {"gt": file_digest(gt)}},
    )
