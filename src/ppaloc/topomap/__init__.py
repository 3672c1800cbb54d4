"""The map: nodes, the snake layout on the PE array, mapping from a traversal, save and load."""

from ppaloc.topomap.build import KEYFRAME_UNITS, build_topomap, describe
from ppaloc.topomap.io import FORMAT_NAME, FORMAT_VERSION, load_map, read_header, save_map
from ppaloc.topomap.layout import KIND_BLOCK_SHAPES, Direction, SnakeLayout, layout_for
from ppaloc.topomap.map import KIND_SPECS, PATCH_LIMIT, TopoMap

__all__ = [
    "FORMAT_NAME",
    "FORMAT_VERSION",
    "KEYFRAME_UNITS",
    "KIND_BLOCK_SHAPES",
    "KIND_SPECS",
    "PATCH_LIMIT",
    "Direction",
    "SnakeLayout",
    "TopoMap",
    "build_topomap",
    "describe",
    "layout_for",
    "load_map",
    "read_header",
    "save_map",
]
