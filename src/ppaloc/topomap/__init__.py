"""The map: nodes, the snake layout on the PE array, save and load."""

from ppaloc.topomap.map import TopoMap

__all__ = ["TopoMap"]
