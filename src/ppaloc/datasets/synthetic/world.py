"""The procedural world: a straight road through segments of town, suburb, forest and fields.

Coordinates (metres): ``s`` along the road (the direction of travel), ``x`` across it
(positive to the right), ``y`` up. The road is two lanes, ``|x| < ROAD_HALF``; the camera
drives in the right lane. Everything is drawn from one seeded generator, so the same seed
gives the same world.

What makes places distinctive: the sequence of buildings (length, height, set-back, colour,
window grid, roof), gaps, trees of several species and sizes, bushes and hedges. What makes
them alias, as real routes do: repeated facade textures, lamp and utility poles at a fixed
spacing, long fences, forest stretches and road markings that look alike everywhere.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ROAD_HALF", "SEGMENT_TYPES", "Boxes", "Planes", "Sprites", "World", "make_world"]

ROAD_HALF = 3.5
"""Half the road width (m): two 3.5 m lanes."""

SEGMENT_TYPES = ("town", "suburb", "forest", "fields")
"""Kinds of surroundings; index = segment code."""

TOWN, SUBURB, FOREST, FIELDS = range(4)


@dataclass(frozen=True)
class Boxes:
    """Buildings: boxes whose road-facing facade is a plane at lateral ``x``.

    All arrays have shape (K,) and are sorted by ``s0``.

    Attributes
    ----------
    s0, s1 : ndarray of float
        Start and end of the facade along the road (m).
    x : ndarray of float
        Lateral position of the facade (m, negative = left side).
    depth, height, roof : ndarray of float
        Box depth away from the road, wall height and roof height (m).
    colour : ndarray of int
        Wall material variant 0..5.
    win_dx, win_dy : ndarray of float
        Window grid spacing along the facade and between floors (m).
    win_w : ndarray of float
        Window width as a fraction of ``win_dx``.
    ident : ndarray of int
        A per-building number (lit-window pattern at night).
    """

    s0: np.ndarray
    s1: np.ndarray
    x: np.ndarray
    depth: np.ndarray
    height: np.ndarray
    roof: np.ndarray
    colour: np.ndarray
    win_dx: np.ndarray
    win_dy: np.ndarray
    win_w: np.ndarray
    ident: np.ndarray


@dataclass(frozen=True)
class Planes:
    """Thin vertical bands parallel to the road: fences, hedges and forest edges.

    Attributes
    ----------
    s0, s1, x, height : ndarray of float, shape (K,)
        Extent along the road, lateral position and (mean) height (m).
    kind : ndarray of int
        0 fence, 1 hedge, 2 forest edge.
    """

    s0: np.ndarray
    s1: np.ndarray
    x: np.ndarray
    height: np.ndarray
    kind: np.ndarray


@dataclass(frozen=True)
class Sprites:
    """Objects drawn facing the camera: trees, bushes, poles.

    Attributes
    ----------
    s, x : ndarray of float, shape (K,)
        Foot position (m), sorted by ``s``.
    width, height : ndarray of float
        World size of the sprite's box (m).
    template : ndarray of int
        Index into the renderer's sprite templates (species / pole type).
    """

    s: np.ndarray
    x: np.ndarray
    width: np.ndarray
    height: np.ndarray
    template: np.ndarray


# Sprite template indices (the renderer draws one image per index).
DECIDUOUS = (0, 1, 2)
CONIFER = (3, 4)
BUSH = (5, 6)
LAMP_POLE = 7
UTILITY_POLE = 8
N_TEMPLATES = 9


@dataclass(frozen=True)
class World:
    """Everything along one route; see the module docstring for coordinates.

    Attributes
    ----------
    length : float
        Route length covered (m).
    seg_start : ndarray of float, shape (S,)
        Start of each segment (m), ascending; ``seg_type`` gives its kind.
    seg_type : ndarray of int, shape (S,)
    boxes, planes, sprites : Boxes, Planes, Sprites
    lamps : ndarray of float, shape (L, 2)
        ``(s, x)`` of every lamp head (4.0 m high over the road edge).
    seed : int
    """

    length: float
    seg_start: np.ndarray
    seg_type: np.ndarray
    boxes: Boxes
    planes: Planes
    sprites: Sprites
    lamps: np.ndarray
    seed: int

    def segment_at(self, s: np.ndarray) -> np.ndarray:
        """Segment code (see :data:`SEGMENT_TYPES`) at positions ``s`` (m)."""
        i = np.searchsorted(self.seg_start, s, side="right") - 1
        return self.seg_type[np.clip(i, 0, self.seg_type.size - 1)]


def _segments(rng: np.random.Generator, begin: float, end: float) -> tuple[np.ndarray, ...]:
    # Markov chain over surroundings: towns give way to suburbs, suburbs to fields or forest.
    nxt = np.array(
        [
            [0.0, 0.7, 0.1, 0.2],
            [0.35, 0.0, 0.3, 0.35],
            [0.15, 0.35, 0.0, 0.5],
            [0.25, 0.35, 0.4, 0.0],
        ]
    )
    lengths = {TOWN: (140, 380), SUBURB: (120, 320), FOREST: (100, 300), FIELDS: (100, 280)}
    starts, types = [], []
    s, t = begin, int(rng.integers(0, 2))
    while s < end:
        starts.append(s)
        types.append(t)
        lo, hi = lengths[t]
        s += float(rng.uniform(lo, hi))
        t = int(rng.choice(4, p=nxt[t]))
    return np.array(starts), np.array(types, dtype=np.int64)


def make_world(length: float, seed: int) -> World:
    """Generate a world covering ``[-60, length + 220]`` metres of road.

    Parameters
    ----------
    length : float
        Metres of road the traversals will drive (the generator adds margins for the
        view ahead).
    seed : int
        Same seed, same world.
    """
    rng = np.random.default_rng([seed, 0x57A7])
    begin, end = -60.0, float(length) + 220.0
    seg_start, seg_type = _segments(rng, begin, end)

    def seg(s: float) -> int:
        return int(seg_type[np.searchsorted(seg_start, s, side="right") - 1])

    box_rows: list[tuple] = []
    plane_rows: list[tuple] = []
    sprite_rows: list[tuple] = []
    lamps: list[tuple[float, float]] = []
    ident = 0

    for side in (-1.0, 1.0):
        # Buildings and the gaps between them, walking along this side of the road.
        s = begin + float(rng.uniform(0, 10))
        while s < end:
            t = seg(s)
            if t == TOWN:
                length_b = rng.uniform(10, 32)
                h = rng.uniform(7, 20)
                row = (rng.uniform(6.5, 9.5), rng.uniform(9, 14), h, rng.choice([0.0, 1.2]))
                gap = rng.choice([rng.uniform(0.5, 3), rng.uniform(6, 16)], p=[0.7, 0.3])
                win = (rng.uniform(2.4, 3.6), rng.uniform(2.8, 3.4), rng.uniform(0.35, 0.6))
            elif t == SUBURB:
                length_b = rng.uniform(8, 15)
                row = (rng.uniform(10, 17), rng.uniform(7, 10), rng.uniform(3.5, 6.5), 0.0)
                row = (*row[:3], rng.uniform(1.8, 3.2))
                gap = rng.uniform(8, 26)
                win = (rng.uniform(2.8, 4.2), rng.uniform(2.7, 3.0), rng.uniform(0.3, 0.5))
            else:
                # Countryside: an occasional barn or farmhouse far from the road.
                if rng.random() < 0.12:
                    length_b = rng.uniform(10, 24)
                    row = (rng.uniform(14, 30), rng.uniform(8, 14), rng.uniform(4, 7), 2.5)
                    win = (rng.uniform(4, 7), 3.0, rng.uniform(0.2, 0.35))
                    gap = rng.uniform(60, 160)
                else:
                    s += float(rng.uniform(20, 60))
                    continue
            x0 = side * (row[0])
            box_rows.append(
                (s, s + length_b, x0, row[1], row[2], row[3], int(rng.integers(0, 6)), *win, ident)
            )
            ident += 1
            if t == SUBURB and rng.random() < 0.6:
                # A hedge in front of the house.
                hx = side * (ROAD_HALF + rng.uniform(2.5, 4.5))
                plane_rows.append((s - 2, s + length_b + 2, hx, rng.uniform(1.0, 1.8), 1))
            s += length_b + float(gap)

        # Vegetation and small objects, sampled on a fine grid along the side.
        s = begin
        while s < end:
            t = seg(s)
            if t == FOREST:
                step = rng.uniform(5, 11)
                sp = rng.choice(CONIFER + DECIDUOUS, p=[0.3, 0.3, 0.15, 0.15, 0.1])
                x = side * rng.uniform(6.5, 11)
            elif t == FIELDS:
                step = rng.uniform(12, 45)
                sp = rng.choice(
                    DECIDUOUS + BUSH + CONIFER, p=[0.2, 0.15, 0.1, 0.25, 0.2, 0.05, 0.05]
                )
                x = side * rng.uniform(7, 25)
            elif t == SUBURB:
                step = rng.uniform(8, 22)
                sp = rng.choice(
                    DECIDUOUS + BUSH + CONIFER, p=[0.25, 0.2, 0.1, 0.15, 0.15, 0.1, 0.05]
                )
                x = side * rng.uniform(ROAD_HALF + 2.5, 9)
            else:
                step = rng.uniform(14, 40)
                sp = rng.choice(DECIDUOUS, p=[0.5, 0.3, 0.2])
                x = side * rng.uniform(ROAD_HALF + 1.2, ROAD_HALF + 2.2)
            sp = int(sp)
            if sp in BUSH:
                w, h = rng.uniform(1.5, 3.5), rng.uniform(0.8, 1.7)
            elif sp in CONIFER:
                h = rng.uniform(7, 16)
                w = h * rng.uniform(0.35, 0.5)
            else:
                h = rng.uniform(5, 13)
                w = h * rng.uniform(0.55, 0.85)
            sprite_rows.append((s, x, w, h, sp))
            s += float(step)

    # Forest edges (a continuous tree line behind the individual trees) and field fences.
    for s0, t, s1 in zip(seg_start, seg_type, [*seg_start[1:], end], strict=True):
        if t == FOREST:
            for side in (-1.0, 1.0):
                plane_rows.append((s0, s1, side * rng.uniform(12, 16), rng.uniform(12, 18), 2))
        elif t == FIELDS:
            for side in (-1.0, 1.0):
                a = s0 + rng.uniform(0, 30)
                while a < s1 - 20:
                    b = min(a + rng.uniform(40, 160), s1)
                    if rng.random() < 0.7:
                        plane_rows.append((a, b, side * (ROAD_HALF + rng.uniform(2, 3)), 1.2, 0))
                    a = b + rng.uniform(10, 50)

    # Poles at a fixed spacing: lamps in built-up areas (right side), utility poles in the
    # countryside (left side). The fixed spacing is deliberate aliasing.
    s = begin
    while s < end:
        t = seg(s)
        if t in (TOWN, SUBURB):
            sprite_rows.append((s, ROAD_HALF + 1.0, 1.6, 7.0, LAMP_POLE))
            lamps.append((s, ROAD_HALF + 1.0 - 1.1))
        else:
            sprite_rows.append((s, -(ROAD_HALF + 2.5), 1.2, 8.5, UTILITY_POLE))
        s += 32.0

    b = np.array(sorted(box_rows), dtype=np.float64).reshape(-1, 11)
    boxes = Boxes(
        s0=b[:, 0], s1=b[:, 1], x=b[:, 2], depth=b[:, 3], height=b[:, 4], roof=b[:, 5],
        colour=b[:, 6].astype(np.int64), win_dx=b[:, 7], win_dy=b[:, 8], win_w=b[:, 9],
        ident=b[:, 10].astype(np.int64),
    )  # fmt: skip
    p = np.array(sorted(plane_rows), dtype=np.float64).reshape(-1, 5)
    planes = Planes(p[:, 0], p[:, 1], p[:, 2], p[:, 3], p[:, 4].astype(np.int64))
    sp = np.array(sorted(sprite_rows), dtype=np.float64).reshape(-1, 5)
    sprites = Sprites(sp[:, 0], sp[:, 1], sp[:, 2], sp[:, 3], sp[:, 4].astype(np.int64))
    return World(
        length=float(length),
        seg_start=seg_start,
        seg_type=seg_type,
        boxes=boxes,
        planes=planes,
        sprites=sprites,
        lamps=np.array(lamps, dtype=np.float64).reshape(-1, 2),
        seed=int(seed),
    )
