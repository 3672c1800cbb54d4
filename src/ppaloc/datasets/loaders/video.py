"""``video:REF.mp4,QUERY.mp4``: one video file per traversal.

Frames are decoded on access with imageio's ffmpeg plugin (the ``imageio-ffmpeg`` package
ships the ffmpeg binary); reading in order is cheap, jumping backwards restarts decoding.
Use ``step`` to keep every step-th frame. Ground truth: ``align=index`` (default) takes
frame ``i`` of both videos as the same place and needs equal frame counts;
``align=proportional`` assumes both traversals moved at constant speed, so query frame ``i``
of ``M`` is at reference frame ``i (N - 1) / (M - 1)``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ppaloc.datasets.frames import FrameSequence
from ppaloc.datasets.frontend import to_grey
from ppaloc.datasets.route import RawRoute
from ppaloc.datasets.spec import DatasetSpec, Key, KindSchema
from ppaloc.errors import DataError

__all__ = ["SCHEMA", "VideoFrames", "load"]

SCHEMA = KindSchema(
    n_paths=(2,),
    keys={
        "align": Key(
            "choice",
            "index",
            "ground truth: same index, or constant-speed proportional",
            choices=("index", "proportional"),
        ),
    },
    example="video:ref.mp4,query.mp4?step=2&align=proportional",
)


class VideoFrames(FrameSequence):
    """Grey frames of a video file, decoded on access.

    Parameters
    ----------
    path : Path
        Any container and codec ffmpeg reads.
    """

    def __init__(self, path: Path, cache: int = 16) -> None:
        self.path = Path(path)
        self._reader = None
        n = self._open().count_frames()
        if n == 0:
            raise DataError(f"video {self.path} has no frames")
        super().__init__(self._frame, range(n), cache)

    def _open(self):
        if self._reader is None:
            import imageio.v2 as iio

            if not self.path.is_file():
                raise DataError(f"video {self.path} does not exist: check the path in the spec")
            try:
                self._reader = iio.get_reader(self.path, format="FFMPEG")
            except Exception as exc:  # imageio/ffmpeg raise many types on a bad file
                raise DataError(f"cannot read video {self.path}: {exc}") from None
        return self._reader

    def _frame(self, i: int) -> np.ndarray:
        try:
            return to_grey(self._open().get_data(i))
        except IndexError:
            raise DataError(f"video {self.path} ends before frame {i}") from None
        except Exception as exc:
            raise DataError(f"cannot decode frame {i} of video {self.path}: {exc}") from None

    def close(self) -> None:
        """Close the decoder (it reopens on the next access)."""
        if self._reader is not None:
            self._reader.close()
            self._reader = None


def load(spec: DatasetSpec) -> RawRoute:
    """Open both videos; the ground truth follows ``align``."""
    ref_path, query_path = spec.paths
    ref, query = VideoFrames(ref_path), VideoFrames(query_path)
    n, m = len(ref), len(query)
    if spec.options["align"] == "index":
        if n != m:
            raise DataError(
                f"reference video {ref_path} has {n} frames but query video {query_path} has "
                f"{m}; align=index needs equal counts: add align=proportional (constant speed)"
            )
        place = np.arange(m, dtype=np.float64)
    else:
        place = np.arange(m, dtype=np.float64) * ((n - 1) / max(m - 1, 1))
    return RawRoute(
        name=f"video {ref_path.name}->{query_path.name}",
        reference=ref,
        query=query,
        default_tolerance=0,
        query_place=place,
        meta={"kind": "video", "reference": str(ref_path), "query": str(query_path)},
    )
