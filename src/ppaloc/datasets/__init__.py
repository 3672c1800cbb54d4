"""Route datasets: loaders, the procedural route generator and the sensor front-end."""

from ppaloc.datasets.base import RouteDataset
from ppaloc.datasets.frontend import SENSOR_SHAPE, to_grey, to_sensor

__all__ = ["SENSOR_SHAPE", "RouteDataset", "to_grey", "to_sensor"]
