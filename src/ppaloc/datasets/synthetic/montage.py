"""A labelled montage of the generator's conditions (the README figure)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from ppaloc.datasets.synthetic.conditions import CONDITIONS
from ppaloc.datasets.synthetic.render import LANE_CENTRE, Renderer
from ppaloc.datasets.synthetic.world import SEGMENT_TYPES, make_world
from ppaloc.fileio import write_png

__all__ = ["conditions_montage", "montage_array", "sequence_strip", "worlds_montage"]


def _views(world, spacing: float) -> list[tuple[str, float]]:
    """One camera position well inside the first segment of each kind of surroundings."""
    out = []
    for code, name in enumerate(SEGMENT_TYPES):
        starts = world.seg_start[(world.seg_type == code) & (world.seg_start >= 0)]
        ends = [world.seg_start[world.seg_start > a].min(initial=world.length) for a in starts]
        for a, b in zip(starts, ends, strict=True):
            if b - a > 80 and a + 40 < world.length:
                out.append((name, round((a + 40) / spacing) * spacing))
                break
    return out


def montage_array(
    seed: int = 1,
    conditions: Sequence[str] | None = None,
    size: int = 256,
    spacing: float = 4.0,
) -> tuple[np.ndarray, list[str], list[str]]:
    """Colour frames: one row per condition, one column per kind of surroundings.

    The last column is the grey image of the first column, as the sensor receives it.

    Returns
    -------
    image : ndarray of uint8, shape (rows * size, cols * size, 3)
    row_names, col_names : list of str
    """
    names = list(conditions or CONDITIONS)
    world = make_world(3000.0, seed)
    views = _views(world, spacing)
    rows = []
    for name in names:
        cond = CONDITIONS[name]
        colour = Renderer(world, cond, size, colour=True, seed=1)
        grey = Renderer(world, cond, size, seed=1)
        x = LANE_CENTRE + cond.offset
        tiles = [colour.render(s, x, (0, k)) for k, (_, s) in enumerate(views)]
        g = grey.render(views[0][1], x, (0, 0))
        tiles.append(np.repeat(g[..., None], 3, axis=2))
        rows.append(np.concatenate(tiles, axis=1))
    cols = [v[0] for v in views] + [f"{views[0][0]}, grey sensor input"]
    return np.concatenate(rows, axis=0), names, cols


def conditions_montage(path: str | os.PathLike, seed: int = 1, size: int = 256) -> Path:
    """Write a labelled PNG montage of every condition (rows) and surroundings (columns).

    Parameters
    ----------
    path : path-like
        Output PNG, written atomically (temporary file, then rename).
    seed : int
        World seed.
    size : int
        Side of each tile in pixels.

    Returns
    -------
    Path
        ``path``.
    """
    grid, row_names, col_names = montage_array(seed, size=size)
    margin_left, margin_top = 90, 26
    h, w, _ = grid.shape
    canvas = Image.new("RGB", (w + margin_left, h + margin_top), (255, 255, 255))
    canvas.paste(Image.fromarray(grid), (margin_left, margin_top))
    draw = ImageDraw.Draw(canvas)
    font = _font(16)
    for k, name in enumerate(col_names):
        draw.text((margin_left + k * size + 6, 4), name, fill=(0, 0, 0), font=font)
    for k, name in enumerate(row_names):
        draw.text((8, margin_top + k * size + size // 2 - 8), name, fill=(0, 0, 0), font=font)
    return _save_png(canvas, path)


def _font(size: int = 16) -> ImageFont.ImageFont:
    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow without FreeType: the fixed bitmap font
        return ImageFont.load_default()


def _save_png(canvas: Image.Image, path: str | os.PathLike) -> Path:
    """Write ``canvas`` as a 256-colour PNG atomically (temporary file, then rename)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # 256 colours keep the figure small enough for a README without visible loss.
    quantized = canvas.quantize(256, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE)
    write_png(path, quantized, optimize=True)
    return path


def sequence_strip(
    path: str | os.PathLike,
    spec: str = "synthetic:?places=200&query=winter&seed=1",
    frames: int = 6,
) -> Path:
    """Write a PNG of query frames of a generated route: moving, then standing at a stop.

    The first half are consecutive frames at cruising speed some way before the first
    stop (content flows outwards from the vanishing point); the second half are
    consecutive frames during the stop (they differ only by noise and snow). Each frame is
    captioned with its index, route position and ``query_moved`` flag.

    Parameters
    ----------
    path : path-like
        Output PNG (written atomically).
    spec : str
        A ``synthetic`` dataset spec.
    frames : int
        Frames in the strip.
    """
    from ppaloc.datasets.registry import load_dataset

    ds = load_dataset(spec)
    s = ds.query_positions[:, 0]
    still = np.flatnonzero(np.diff(s) == 0)
    stop = int(still[0]) + 1 if still.size else len(s) // 2
    half = frames // 2
    moving = max(stop - 25, 0)
    idx = list(range(moving, moving + half)) + list(range(stop, stop + frames - half))
    size = ds.query[0].shape[1]
    top = 24
    canvas = Image.new("RGB", (size * len(idx), size + top), (255, 255, 255))
    draw = ImageDraw.Draw(canvas)
    font = _font(14)
    for k, i in enumerate(idx):
        canvas.paste(Image.fromarray(ds.query[i]).convert("RGB"), (k * size, top))
        moved = "moved" if ds.query_moved[i] else "still"
        draw.text((k * size + 6, 4), f"#{i}  {s[i]:.1f} m  {moved}", fill=(0, 0, 0), font=font)
    return _save_png(canvas, path)


WORLD_ROWS = (
    ("lab", "world=lab&places=160", ("lab", "changed", "moved", "people", "dim")),
    ("road, turns", "turns=8&places=400", ("summer", "winter", "night")),
)
"""The montage of :func:`worlds_montage`: label, spec keys and query conditions per world."""


def _pick_frames(turning: np.ndarray, n: int = 4) -> list[int]:
    """Half straight frames, half the middle frames of turns, spread over the route."""
    straight = np.flatnonzero(~turning)
    turn = np.flatnonzero(turning)
    spans = np.split(turn, np.flatnonzero(np.diff(turn) > 1) + 1) if turn.size else []
    half = n // 2 if spans else 0
    picks = [int(straight[int(len(straight) * q)]) for q in np.linspace(0.2, 0.8, n - half)]
    step = max(len(spans) // max(half, 1), 1)
    picks += [int(spans[k][len(spans[k]) // 2]) for k in range(0, step * half, step)][:half]
    return sorted(picks)


def worlds_montage(path: str | os.PathLike, seed: int = 1, frames: int = 4) -> Path:
    """Write a labelled PNG of the lab and the road with turns under each query condition.

    One row per world and condition (the same frame-synchronised places in every row of a
    world), ``frames`` columns: half on straight stretches, half in the middle of turns,
    each captioned with its frame index and ``straight`` or ``turning``. Grey 256x256
    frames, as ``load_dataset`` serves them.

    Parameters
    ----------
    path : path-like
        Output PNG (written atomically).
    seed : int
        World seed.
    frames : int
        Columns.
    """
    from ppaloc.datasets.registry import load_dataset

    size, left, cap = 256, 150, 20
    blocks = []
    for label, keys, conditions in WORLD_ROWS:
        for k, name in enumerate(conditions):
            ds = load_dataset(f"synthetic:?{keys}&sync=1&seed={seed}&query={name}")
            turning = np.asarray(ds.meta["query_turning"], bool)
            if k == 0:
                idx = _pick_frames(turning, frames)
            blocks.append((f"{label}: {name}", [ds.query[i] for i in idx], idx, turning))
    canvas = Image.new("RGB", (left + frames * size, len(blocks) * (size + cap)), "white")
    draw = ImageDraw.Draw(canvas)
    font = _font(15)
    for r, (name, tiles, idx, turning) in enumerate(blocks):
        y = r * (size + cap)
        draw.text((8, y + cap + size // 2 - 8), name, fill=(0, 0, 0), font=font)
        for c, (tile, i) in enumerate(zip(tiles, idx, strict=True)):
            canvas.paste(Image.fromarray(tile).convert("RGB"), (left + c * size, y + cap))
            where = "turning" if turning[i] else "straight"
            draw.text((left + c * size + 6, y + 2), f"#{i} {where}", fill=(0, 0, 0), font=font)
    return _save_png(canvas, path)
