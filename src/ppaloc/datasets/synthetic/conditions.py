"""Named appearance conditions: palette, light, weather and sensor noise.

The renderer draws *materials* (road, wall, leaves, ...) and a shading factor; a condition
turns them into colour through its palette, then adds light, fog, snow and noise. So all
traversals share the geometry of the world and differ only in appearance (and in the
camera's lateral offset), which is exactly the change a place recogniser must survive.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["CONDITIONS", "MATERIALS", "Condition", "condition"]

MATERIALS = (
    "sky", "road", "marking", "sidewalk", "verge", "field",
    "wall0", "wall1", "wall2", "wall3", "wall4", "wall5", "window", "window_lit", "roof", "door",
    "trunk", "leaves0", "leaves1", "conifer", "bush", "pole", "lamp", "fence",
    "hedge", "hill", "snowcap", "forest",
    # indoors (the lab world)
    "floor", "floor_line", "carpet", "ceiling", "ceiling_line", "light",
    "lwall0", "lwall1", "lwall2", "lwall3", "skirting", "ldoor",
    "poster0", "poster1", "poster2", "poster3", "desk", "cabinet", "shelf", "sofa",
    "plant", "pot", "metal", "skin", "cloth0", "cloth1", "cloth2", "hair", "cardboard",
    "plastic", "ldark",
)  # fmt: skip
"""Material names; a material's id is its index."""

M = {name: i for i, name in enumerate(MATERIALS)}

EMISSIVE = (M["window_lit"], M["lamp"])
"""Materials that give light rather than reflect it (kept bright at night)."""

_SUMMER = {
    "sky": (120, 170, 225),
    "road": (92, 92, 96),
    "marking": (225, 225, 215),
    "sidewalk": (165, 160, 152),
    "verge": (86, 140, 60),
    "field": (120, 160, 70),
    "wall0": (200, 170, 140),
    "wall1": (170, 90, 70),
    "wall2": (215, 210, 195),
    "wall3": (130, 140, 150),
    "wall4": (225, 195, 110),
    "wall5": (95, 85, 80),
    "window": (50, 65, 85),
    "window_lit": (50, 65, 85),
    "roof": (120, 60, 50),
    "door": (80, 55, 40),
    "trunk": (85, 65, 45),
    "leaves0": (55, 115, 40),
    "leaves1": (90, 140, 50),
    "conifer": (35, 80, 40),
    "bush": (70, 120, 45),
    "pole": (110, 110, 110),
    "lamp": (200, 200, 190),
    "fence": (140, 115, 85),
    "hedge": (50, 100, 40),
    "hill": (110, 140, 150),
    "snowcap": (35, 80, 40),
    "forest": (40, 85, 42),
    "floor": (150, 140, 125),
    "floor_line": (110, 105, 95),
    "carpet": (90, 95, 110),
    "ceiling": (225, 225, 220),
    "ceiling_line": (185, 185, 180),
    "light": (255, 255, 250),
    "lwall0": (215, 210, 195),
    "lwall1": (180, 195, 205),
    "lwall2": (200, 180, 160),
    "lwall3": (160, 170, 150),
    "skirting": (70, 70, 75),
    "ldoor": (120, 85, 55),
    "poster0": (200, 60, 50),
    "poster1": (40, 80, 160),
    "poster2": (230, 200, 60),
    "poster3": (30, 30, 35),
    "desk": (165, 125, 80),
    "cabinet": (130, 135, 140),
    "shelf": (95, 75, 55),
    "sofa": (60, 90, 120),
    "plant": (50, 120, 50),
    "pot": (150, 80, 50),
    "metal": (170, 170, 175),
    "skin": (210, 170, 140),
    "cloth0": (40, 50, 90),
    "cloth1": (160, 40, 40),
    "cloth2": (90, 90, 90),
    "hair": (50, 35, 25),
    "cardboard": (180, 140, 90),
    "plastic": (60, 60, 65),
    "ldark": (25, 25, 30),
}


@dataclass(frozen=True)
class Condition:
    """How one traversal looks.

    Attributes
    ----------
    name : str
    palette : dict of str -> (r, g, b)
        Overrides of the summer palette (0-255).
    sky_top, sky_horizon : (r, g, b)
        Sky gradient; clouds are mixed in by ``cloud_cover`` toward ``cloud_colour``.
    gain, bias, gamma : float
        Brightness and contrast: ``out = 255 * (gain * v / 255 + bias) ** gamma``.
    fog_distance : float
        Metres at which fog hides 63% of the scene (``inf``: clear).
    fog_colour : (r, g, b)
    noise_sigma : float
        Sensor noise, grey levels (Gaussian, plus shot noise scaling with brightness).
    snowfall : int
        Falling flakes per 256x256 frame.
    snow : bool
        Snow lies on conifers (the palette whitens ground, roofs and bushes).
    foliage : float
        Fraction of a deciduous crown that has leaves (winter 0.0: bare branches).
    night : bool
        Lights on: headlights, street lamps, lit windows; daylight reduced to ``ambient``.
    ambient : float
        With ``night``, the light left away from lamps and headlights (fraction of day).
    offset : float
        The camera's lateral offset from the reference lane position (m).
    """

    name: str
    palette: dict = field(default_factory=dict)
    sky_top: tuple = (70, 120, 200)
    sky_horizon: tuple = (175, 205, 230)
    cloud_cover: float = 0.35
    cloud_colour: tuple = (245, 245, 245)
    gain: float = 1.0
    bias: float = 0.0
    gamma: float = 1.0
    fog_distance: float = 450.0
    fog_colour: tuple = (190, 205, 220)
    noise_sigma: float = 1.5
    snowfall: int = 0
    foliage: float = 1.0
    snow: bool = False
    night: bool = False
    ambient: float = 0.16
    offset: float = 0.0

    def rgb_lut(self) -> np.ndarray:
        """Material colours, shape (n_materials, 3), float32 in 0..255."""
        colours = {**_SUMMER, **self.palette}
        return np.array([colours[m] for m in MATERIALS], dtype=np.float32)


CONDITIONS: dict[str, Condition] = {
    "summer": Condition("summer"),
    "autumn": Condition(
        "autumn",
        palette={
            "leaves0": (190, 95, 30),
            "leaves1": (215, 160, 45),
            "bush": (150, 90, 40),
            "verge": (120, 115, 60),
            "field": (150, 130, 80),
            "hedge": (120, 85, 35),
            "road": (70, 70, 74),
            "forest": (95, 70, 35),
            "hill": (120, 125, 125),
        },
        sky_top=(140, 150, 160),
        sky_horizon=(190, 190, 185),
        cloud_cover=0.75,
        cloud_colour=(215, 215, 215),
        gain=0.92,
        bias=-0.02,
        fog_distance=160.0,
        fog_colour=(175, 175, 170),
        noise_sigma=2.5,
        foliage=0.75,
        offset=0.4,
    ),
    "winter": Condition(
        "winter",
        palette={
            "verge": (235, 238, 242),
            "field": (240, 242, 246),
            "sidewalk": (215, 218, 222),
            "road": (120, 120, 125),
            "roof": (240, 242, 245),
            "hedge": (200, 205, 210),
            "bush": (215, 218, 222),
            "snowcap": (240, 242, 246),
            "fence": (100, 85, 70),
            "hill": (205, 210, 218),
            "forest": (70, 80, 75),
        },
        sky_top=(175, 185, 200),
        sky_horizon=(220, 222, 228),
        cloud_cover=0.9,
        cloud_colour=(225, 225, 230),
        gain=0.95,
        bias=0.02,
        gamma=1.1,
        fog_distance=110.0,
        fog_colour=(215, 218, 225),
        noise_sigma=3.0,
        snowfall=260,
        foliage=0.0,
        snow=True,
        offset=-0.5,
    ),
    "night": Condition(
        "night",
        palette={"window_lit": (255, 215, 140), "lamp": (255, 240, 200)},
        sky_top=(12, 14, 30),
        sky_horizon=(75, 66, 72),  # the glow of a town's lights on the haze
        cloud_cover=0.2,
        cloud_colour=(40, 40, 55),
        fog_distance=700.0,
        fog_colour=(20, 22, 30),
        noise_sigma=6.0,
        night=True,
        offset=0.6,
    ),
    "dusk": Condition(
        "dusk",
        palette={"window_lit": (255, 210, 140), "lamp": (255, 235, 190)},
        sky_top=(60, 70, 120),
        sky_horizon=(235, 150, 90),
        cloud_cover=0.3,
        cloud_colour=(200, 120, 110),
        gain=0.95,
        fog_distance=300.0,
        fog_colour=(150, 110, 100),
        noise_sigma=4.0,
        night=True,
        ambient=0.5,
        offset=-0.3,
    ),
}
"""The named conditions; ``summer`` is the usual reference."""


def condition(name: str) -> Condition:
    """Return the condition called ``name`` (``KeyError`` lists the names)."""
    try:
        return CONDITIONS[name]
    except KeyError:
        raise KeyError(f"unknown condition {name!r}; choose from {', '.join(CONDITIONS)}") from None
