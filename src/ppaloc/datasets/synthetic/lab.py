"""The indoor laboratory: corridors and rooms seen from a small robot, under changes.

The paper's third dataset is a simulated laboratory in which a robot maps a route, the scene
is changed, and the robot re-localises. This world is its procedural counterpart, in the
same route coordinates as the road (``s`` along the route, ``x`` across): corridors 2.2 m
wide with painted walls, doors, posters, skirting, and now and then a cabinet, a plant, a
bin or a chair; rooms 5-9 m wide with desks, cabinets, shelves and sofas along the walls
and chairs, plants and boxes in front of them; a ceiling of tiles with light panels every
2.4 m; a tiled floor in corridors and carpet in rooms. The camera is 0.45 m above the floor
(a robot's), places are 0.5 m apart, and the route turns at corridor corners (radius
0.8-2 m) and on curves through rooms (radius 3-8 m; every such turn gets a room around it).

A *lab condition* is an appearance (:class:`~.conditions.Condition`) plus changes to the
scene applied to the world before rendering: objects moved, removed or added, people
present, light panels switched off. The map traversal normally uses ``lab`` (no change).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ppaloc.datasets.synthetic.conditions import Condition, M
from ppaloc.datasets.synthetic.curved import CurvedRenderer
from ppaloc.datasets.synthetic.path import RoutePath, make_path
from ppaloc.datasets.synthetic.sprites import TH, TRANSPARENT, TW, smooth_noise
from ppaloc.datasets.synthetic.world import Boxes, Planes, Sprites, World

__all__ = [
    "LAB_CONDITIONS",
    "LAB_HEIGHT",
    "LAB_SPACING",
    "LabCondition",
    "LabRenderer",
    "change_world",
    "make_lab",
]

LAB_SPACING = 0.5
"""Default metres between places in the lab."""

LAB_HEIGHT = 0.45
"""Camera height over the floor (m): a small mobile robot."""

CEILING = 2.7
"""Ceiling and wall height (m)."""

HALF = 1.1
"""Half the corridor width (m)."""

CORRIDOR, ROOM = 0, 1
PLANT, BIN, CHAIR, BOX, STAND, PERSON_A, PERSON_B = range(7)
_FURNITURE = 6  # box colour codes >= 6 are furniture: desk, cabinet, shelf, sofa


@dataclass(frozen=True)
class LabCondition:
    """A lab traversal: an appearance and the changes made to the scene before it.

    Attributes
    ----------
    condition : Condition
        Palette, light level (``gain``), fog and noise.
    moved, removed, added : float
        Fractions of the furniture and small objects moved (0.4-1.5 m along the wall),
        removed, and added as new objects.
    people : float
        People standing beside the route, per 10 m.
    panels_on : float
        Fraction of the ceiling light panels switched on.
    """

    condition: Condition
    moved: float = 0.0
    removed: float = 0.0
    added: float = 0.0
    people: float = 0.0
    panels_on: float = 1.0

    @property
    def name(self) -> str:
        return self.condition.name


_INDOOR = {
    "sky_top": (28, 28, 32),
    "sky_horizon": (28, 28, 32),
    "cloud_cover": 0.0,
    "fog_distance": 22.0,
    "fog_colour": (60, 60, 64),
    "noise_sigma": 2.0,
}

LAB_CONDITIONS: dict[str, LabCondition] = {
    "lab": LabCondition(Condition("lab", **_INDOOR)),
    "changed": LabCondition(
        Condition("changed", **_INDOOR, offset=0.05),
        moved=0.3,
        removed=0.2,
        added=0.2,
        people=1.5,
    ),
    "moved": LabCondition(
        Condition("moved", **_INDOOR, offset=0.05), moved=0.3, removed=0.2, added=0.2
    ),
    "people": LabCondition(Condition("people", **_INDOOR, offset=0.05), people=2.0),
    "dim": LabCondition(
        Condition("dim", **{**_INDOOR, "noise_sigma": 4.0, "fog_distance": 14.0}, gain=0.55),
        panels_on=0.5,
    ),
}
"""The named lab conditions: ``lab`` (the map), ``changed`` (objects moved, removed and
added, and people present), ``moved`` (objects only), ``people`` (people only), ``dim``
(half the light panels off, the rest dimmed)."""


def _sorted_boxes(rows: list[tuple]) -> Boxes:
    b = np.array(sorted(rows), dtype=np.float64).reshape(-1, 11)
    return Boxes(
        s0=b[:, 0], s1=b[:, 1], x=b[:, 2], depth=b[:, 3], height=b[:, 4], roof=b[:, 5],
        colour=b[:, 6].astype(np.int64), win_dx=b[:, 7], win_dy=b[:, 8], win_w=b[:, 9],
        ident=b[:, 10].astype(np.int64),
    )  # fmt: skip


def _sorted_sprites(rows: list[tuple]) -> Sprites:
    sp = np.array(sorted(rows), dtype=np.float64).reshape(-1, 5)
    return Sprites(sp[:, 0], sp[:, 1], sp[:, 2], sp[:, 3], sp[:, 4].astype(np.int64))


_SIZES = {  # (width, height) ranges in metres
    PLANT: ((0.45, 0.7), (0.8, 1.5)),
    BIN: ((0.3, 0.4), (0.35, 0.55)),
    CHAIR: ((0.45, 0.55), (0.85, 1.0)),
    BOX: ((0.4, 0.7), (0.3, 0.6)),
    STAND: ((0.45, 0.6), (1.6, 1.85)),
    PERSON_A: ((0.5, 0.6), (1.55, 1.9)),
    PERSON_B: ((0.5, 0.6), (1.55, 1.9)),
}


def _object(rng: np.random.Generator, s: float, x: float, kind: int) -> tuple:
    (w0, w1), (h0, h1) = _SIZES[kind]
    return (s, x, float(rng.uniform(w0, w1)), float(rng.uniform(h0, h1)), kind)


def _room_width(world: World, s: float) -> float:
    return HALF if world.segment_at(np.array([s]))[0] == CORRIDOR else 3.5


def make_lab(length: float, end: float, turns: int, seed: int) -> tuple[World, RoutePath]:
    """Generate the lab covering ``[-10, length + 40]`` m and its route with ``turns`` turns.

    Returns
    -------
    (World, RoutePath)
        The scene (walls and furniture as boxes, small objects as sprites) and the route's
        heading. Same seed, same lab.
    """
    rng = np.random.default_rng([seed, 0x1AB])
    begin, stop = -10.0, float(length) + 40.0
    path = make_path(begin, stop, end, turns, seed, indoor=True)
    rooms = []
    corners = []
    for a, b, _ in path.turns:
        if b - a > 2.5:  # a curve: the robot turns through a room
            rooms.append((a - rng.uniform(1.5, 3.0), b + rng.uniform(1.5, 3.0)))
        else:
            corners.append((a - 1.0, b + 1.0))
    s = begin + float(rng.uniform(4, 10))
    while s < stop:
        size = float(rng.uniform(5, 10))
        if not any(a < s + size and s < b for a, b in corners):
            rooms.append((s, s + size))
        s += size + float(rng.uniform(8, 20))
    rooms.sort()
    merged: list[list[float]] = []
    for a, b in rooms:
        if merged and a < merged[-1][1] + 2.0:
            merged[-1][1] = max(merged[-1][1], b)
        else:
            merged.append([a, b])
    seg_start, seg_type = [begin], [CORRIDOR]
    for a, b in merged:
        if a <= seg_start[-1]:
            seg_type[-1] = ROOM
        else:
            seg_start.append(a)
            seg_type.append(ROOM)
        seg_start.append(b)
        seg_type.append(CORRIDOR)
    bounds = [*seg_start[1:], stop]
    boxes: list[tuple] = []
    sprites: list[tuple] = []
    ident = 0
    for side in (-1.0, 1.0):
        width = HALF
        for s0, t, s1 in zip(seg_start, seg_type, bounds, strict=True):
            if t == ROOM:
                width = float(rng.uniform(2.5, 4.5))
                boxes.append(
                    (s0, s1, side * width, 0.15, CEILING, 0.0, int(rng.integers(0, 4)),
                     rng.uniform(3.0, 6.0), 1.0, 0.5, ident)
                )  # fmt: skip
                ident += 1
                a = s0 + float(rng.uniform(0.2, 0.8))
                while a < s1 - 0.8:
                    length_f = float(min(rng.uniform(0.8, 2.2), s1 - a - 0.2))
                    depth_f = float(rng.uniform(0.5, 0.9))
                    kind = int(rng.integers(0, 4))
                    h = (0.75, 1.9, 1.8, 0.85)[kind] * float(rng.uniform(0.9, 1.1))
                    boxes.append(
                        (a, a + length_f, side * (width - depth_f), depth_f, h, 0.0,
                         _FURNITURE + kind, 0.35, 0.4, 0.5, ident)
                    )  # fmt: skip
                    ident += 1
                    if rng.random() < 0.6:
                        kind_o = int(rng.choice([CHAIR, PLANT, BOX, BIN]))
                        x_o = side * (width - depth_f - float(rng.uniform(0.3, 0.9)))
                        sprites.append(_object(rng, a + length_f / 2, x_o, kind_o))
                    a += length_f + float(rng.uniform(0.1, 1.5))
                continue
            a, closing = s0, width  # the first wall after a room closes it
            while a < s1:
                length_w = float(min(rng.uniform(2.0, 6.0), s1 - a))
                boxes.append(
                    (a, a + length_w, side * HALF, max(closing - HALF, 0.15), CEILING, 0.0,
                     int(rng.integers(0, 4)), rng.uniform(2.5, 5.0), 1.0, 0.5, ident)
                )  # fmt: skip
                ident += 1
                closing = HALF
                if rng.random() < 0.35:
                    kind_o = int(rng.choice([PLANT, BIN, CHAIR, STAND, BOX]))
                    sprites.append(_object(rng, a + length_w / 2, side * (HALF - 0.25), kind_o))
                a += length_w
            width = HALF
    world = World(
        length=float(length),
        seg_start=np.array(seg_start, np.float64),
        seg_type=np.array(seg_type, np.int64),
        boxes=_sorted_boxes(boxes),
        planes=Planes(*(np.zeros(0) for _ in range(4)), np.zeros(0, np.int64)),
        sprites=_sorted_sprites(sprites),
        lamps=np.zeros((0, 2)),
        seed=int(seed),
    )
    return world, path


def change_world(world: World, cond: LabCondition, seed: int) -> World:
    """The lab as a traversal under ``cond`` finds it: objects moved, removed, added, people.

    Walls never change; furniture and small objects are moved along the route by 0.4-1.5 m
    (either way), removed, or added (copies of existing objects at new places); people
    stand beside the route (at least 0.45 m from its centre line). Seeded by ``seed``.
    """
    if not (cond.moved or cond.removed or cond.added or cond.people):
        return world
    rng = np.random.default_rng([world.seed, 0xC4A6, seed])
    b = world.boxes
    rows = [
        tuple(float(getattr(b, f)[i]) for f in Boxes.__dataclass_fields__) for i in range(b.s0.size)
    ]
    sp = world.sprites
    objs = [
        (
            float(sp.s[i]),
            float(sp.x[i]),
            float(sp.width[i]),
            float(sp.height[i]),
            int(sp.template[i]),
        )
        for i in range(sp.s.size)
    ]

    def perturb(items, movable, shift_index):
        out, pool = [], []
        for row in items:
            if not movable(row):
                out.append(row)
                continue
            r = rng.random()
            if r < cond.removed:
                continue
            row = list(row)
            if r < cond.removed + cond.moved:
                d = float(rng.uniform(0.4, 1.5)) * float(rng.choice([-1, 1]))
                for k in shift_index:
                    row[k] += d
            out.append(tuple(row))
            pool.append(tuple(row))
        n_add = round(cond.added * len(pool))
        for _ in range(n_add):
            row = list(pool[int(rng.integers(0, len(pool)))])
            d = float(rng.uniform(2.0, 12.0)) * float(rng.choice([-1, 1]))
            for k in shift_index:
                row[k] += d
            out.append(tuple(row))
        return out

    ident = max((int(r[10]) for r in rows), default=0) + 1
    rows = perturb(rows, lambda r: r[6] >= _FURNITURE, (0, 1))
    rows = [(*r[:10], float(ident + i)) if r[6] >= _FURNITURE else r for i, r in enumerate(rows)]
    objs = perturb(objs, lambda o: True, (0,))
    n_people = round(cond.people * (world.length + 20.0) / 10.0)
    for _ in range(n_people):
        s = float(rng.uniform(-5.0, world.length + 15.0))
        room = _room_width(world, s)
        x = float(rng.uniform(0.45, max(room - 0.4, 0.6))) * float(rng.choice([-1, 1]))
        objs.append(_object(rng, s, x, int(rng.choice([PERSON_A, PERSON_B]))))
    return replace(world, boxes=_sorted_boxes(rows), sprites=_sorted_sprites(objs))


def lab_templates(seed: int) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Material and shading images of the lab's small objects and people."""
    rng = np.random.default_rng([seed, 0x7E3])
    v, h = np.mgrid[0:TH, 0:TW].astype(np.float32)
    v, h = (v + 0.5) / TH, (h + 0.5) / TW
    mats, shades = [], []
    for kind in range(7):
        m = np.full((TH, TW), TRANSPARENT, np.uint8)
        if kind == PLANT:
            m[(v > 0.72) & (np.abs(h - 0.5) < 0.24 - 0.08 * (v - 0.72) / 0.28)] = M["pot"]
            leaves = smooth_noise(rng, (TH, TW), 10)
            crown = ((v - 0.4) / 0.34) ** 2 + ((h - 0.5) / 0.5) ** 2 < 1.0
            m[crown & (leaves > 0.3)] = M["plant"]
        elif kind == BIN:
            m[(v > 0.05) & (np.abs(h - 0.5) < 0.42 - 0.1 * v)] = M["plastic"]
            m[(v > 0.05) & (v < 0.12) & (np.abs(h - 0.5) < 0.42)] = M["metal"]
        elif kind == CHAIR:
            m[(v > 0.05) & (v < 0.5) & (np.abs(h - 0.5) < 0.38)] = M["cloth0"]
            m[(v >= 0.5) & (v < 0.6) & (np.abs(h - 0.5) < 0.46)] = M["cloth2"]
            m[(v >= 0.6) & ((np.abs(h - 0.12) < 0.04) | (np.abs(h - 0.88) < 0.04))] = M["metal"]
        elif kind == BOX:
            m[(v > 0.04) & (np.abs(h - 0.5) < 0.46)] = M["cardboard"]
            m[(v > 0.04) & (np.abs(h - 0.5) < 0.04)] = M["floor_line"]
        elif kind == STAND:
            m[np.abs(h - 0.5) < 0.04] = M["metal"]
            m[(v > 0.95) & (np.abs(h - 0.5) < 0.35)] = M["metal"]
            m[((v - 0.3) / 0.22) ** 2 + ((h - 0.5) / 0.45) ** 2 < 1.0] = M["cloth1"]
        else:
            top = M["cloth1"] if kind == PERSON_A else M["cloth0"]
            m[((v - 0.075) / 0.07) ** 2 + ((h - 0.5) / 0.17) ** 2 < 1.0] = M["skin"]
            m[((v - 0.06) / 0.05) ** 2 + ((h - 0.5) / 0.18) ** 2 < 1.0] = M["hair"]
            torso = (v > 0.15) & (v < 0.55) & (np.abs(h - 0.5) < 0.3)
            arms = (v > 0.16) & (v < 0.5) & (np.abs(h - 0.5) >= 0.3) & (np.abs(h - 0.5) < 0.42)
            m[torso | arms] = top
            legs = (v >= 0.55) & (np.abs(h - 0.5) > 0.03) & (np.abs(h - 0.5) < 0.24)
            m[legs] = M["cloth2"]
        noise = smooth_noise(rng, (TH, TW), 12)
        shades.append((0.8 + 0.25 * noise + 0.15 * (1 - h)).astype(np.float32))
        mats.append(m)
    return mats, shades


class LabRenderer(CurvedRenderer):
    """Renders the lab under a :class:`LabCondition` (ceiling, floor, walls, furniture)."""

    def __init__(
        self,
        world: World,
        lab: LabCondition,
        size: int = 256,
        colour: bool = False,
        seed: int = 0,
        *,
        path: RoutePath,
    ) -> None:
        self.lab = lab
        super().__init__(
            world, lab.condition, size, colour, seed, path=path, height=LAB_HEIGHT, z_far=30.0
        )
        self.tmat, self.tshade = lab_templates(world.seed)
        rows = int(np.searchsorted(self.ys, self.cy - 0.5))
        self._zc = (self.f * (CEILING - self.h) / (self.cy - self.ys[:rows])).astype(np.float32)
        self._xrel_c = ((self.xs - self.cx)[None, :] * self._zc[:, None] / self.f).astype(
            np.float32
        )
        mats = {c: M["lwall0"] + c for c in range(4)} | {
            _FURNITURE + k: M[n] for k, n in enumerate(("desk", "cabinet", "shelf", "sofa"))
        }
        self._wall_mat = mats

    def _ground_luts(self):
        n = 2 * 80 * 48
        mats = np.stack([np.full(n, M["floor"], np.uint8), np.full(n, M["carpet"], np.uint8)])
        return mats, np.ones((2, n), np.float32), np.zeros(n, bool)

    def _ground_extra(self, m, sw, x):
        tiles = ((sw % 0.5) < 0.02)[:, None] | ((x % 24) == 0)
        m[tiles & (m == M["floor"])] = M["floor_line"]

    def geometry(self, s_cam, x_cam):
        S = self.S
        mat = np.full((S, S), M["sky"], np.uint8)
        shade = np.ones((S, S), np.float32)
        depth = np.full((S, S), np.inf, np.float32)
        self._ceiling(mat, shade, depth, s_cam, x_cam)
        self._ground(mat, shade, depth, s_cam, x_cam)
        self._boxes(mat, shade, depth, s_cam, x_cam)
        self._sprites(mat, shade, depth, s_cam, x_cam)
        return mat, shade, depth

    def _ceiling(self, mat, shade, depth, s_cam, x_cam):
        z = self._zc
        n = z.size
        sw = z.astype(np.float64) + s_cam
        x = self._xrel_c + (x_cam - self.lateral(z)).astype(np.float32)[:, None]
        m = np.full((n, self.S), M["ceiling"], np.uint8)
        lines = ((sw % 0.6) < 0.03)[:, None] | ((x % np.float32(0.6)) < 0.03)
        m[lines] = M["ceiling_line"]
        panel = np.floor(sw / 2.4).astype(np.int64)
        on = ((sw % 2.4) < 0.6) & (((panel * 2654435761) % 997) < 997 * self.lab.panels_on)
        m[on[:, None] & (np.abs(x) < 0.35)] = M["light"]
        mat[:n] = m
        depth[:n] = z[:, None]

    def _windows(self, i, u, v, wall_h):
        # Terms of ``u`` alone stay one row (1, C) and broadcast against ``v`` (R, C).
        b = self.world.boxes
        colour, ident = int(b.colour[i]), int(b.ident[i])
        shape = v.shape
        u = np.broadcast_to(u, (1, shape[1]))
        m = np.full(shape, self._wall_mat[colour], np.uint8)
        if colour >= _FURNITURE:
            kind = colour - _FURNITURE
            if kind == 0:  # desk: a top, a dark space under it, a drawer block on one end
                under = v < wall_h - 0.06
                m[under] = M["ldark"]
                m[under & (u < 0.45)] = M["desk"]
                m[(np.abs(v - 0.45) < 0.01) & (u < 0.45)] = M["floor_line"]
            elif kind == 1:  # cabinet: doors and handles
                m[np.broadcast_to(np.abs((u % 0.5) - 0.25) > 0.23, shape)] = M["floor_line"]
                m[(np.abs((u % 0.5) - 0.4) < 0.02) & (np.abs(v - 1.0) < 0.12)] = M["metal"]
            elif kind == 2:  # shelf: boards with rows of books
                book = ((np.floor(u * 25.0) * 7919 + ident) % 4).astype(np.int64)
                m[:] = (M["poster0"] + book).astype(np.uint8)
                m[(v % 0.4) < 0.05] = M["shelf"]
            else:  # sofa: seat and back
                m[v < 0.4] = M["cloth2"]
            return m
        m[v < 0.1] = M["skirting"]
        wx = b.win_dx[i]
        col = np.floor(u / wx)
        fu = u / wx - col
        which = (col + ident) % 3
        off = np.abs(fu - 0.5) * wx
        door = ((which == 0) & (off < 0.45)) & (v < 2.05)
        m[door] = M["ldoor"]
        m[door & (off > 0.4)] = M["skirting"]
        poster = ((which == 1) & (off < 0.3)) & (np.abs(v - 1.45) < 0.4)
        kind = (col.astype(np.int64) * 7 + ident) % 4
        m[poster] = (M["poster0"] + np.broadcast_to(kind, shape)[poster]).astype(np.uint8)
        stripe = poster & (np.abs(v - 1.3) < 0.06)
        m[stripe] = M["lwall0"]
        return m
