"""Route datasets: loaders, the procedural route generator and the sensor front-end.

``load_dataset("KIND:PATH?key=value")`` is the entry point; see ``docs/datasets.md``.
"""

from ppaloc.datasets.base import RouteDataset
from ppaloc.datasets.frames import FrameSequence, ImageFrames, RenderedFrames
from ppaloc.datasets.registry import KINDS, load_dataset, parse_dataset_spec
from ppaloc.datasets.synthetic import CONDITIONS, make_synthetic
from ppaloc.frontend import SENSOR_SHAPE, to_grey, to_sensor

__all__ = [
    "CONDITIONS",
    "KINDS",
    "SENSOR_SHAPE",
    "FrameSequence",
    "ImageFrames",
    "RenderedFrames",
    "RouteDataset",
    "load_dataset",
    "make_synthetic",
    "parse_dataset_spec",
    "to_grey",
    "to_sensor",
]
