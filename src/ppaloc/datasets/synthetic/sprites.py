"""Sprite templates: trees, bushes and poles as small material images.

Each template is a (TH, TW) array of material ids (``TRANSPARENT`` outside the object)
and a shading array. The geometry of a template (trunk, branches, crown outline) depends
only on the world seed, so a tree keeps its shape across conditions; the condition decides
how much of the crown is in leaf (``foliage``) and whether snow lies on it.
"""

from __future__ import annotations

import numpy as np
from PIL import Image

from ppaloc.datasets.synthetic.conditions import Condition, M
from ppaloc.datasets.synthetic.world import (
    BUSH,
    CONIFER,
    DECIDUOUS,
    LAMP_POLE,
    N_TEMPLATES,
    UTILITY_POLE,
)

__all__ = ["TH", "TRANSPARENT", "TW", "make_templates", "smooth_noise"]

TH, TW = 128, 96
TRANSPARENT = 255


def smooth_noise(rng: np.random.Generator, shape: tuple[int, int], cells: int) -> np.ndarray:
    """Value noise in [0, 1]: a ``cells``-wide random grid upsampled bicubically, two octaves."""
    out = np.zeros(shape, np.float32)
    for octave, weight in ((1, 0.65), (3, 0.35)):
        gh = max(2, round(cells * octave * shape[0] / max(shape)))
        gw = max(2, round(cells * octave * shape[1] / max(shape)))
        grid = rng.random((gh, gw), dtype=np.float32)
        img = Image.fromarray(grid, mode="F").resize((shape[1], shape[0]), Image.Resampling.BICUBIC)
        out += weight * np.asarray(img, np.float32)
    lo, hi = float(out.min()), float(out.max())
    return (out - lo) / max(hi - lo, 1e-6)


def _line(mat: np.ndarray, p0, p1, width: float, material: int) -> None:
    """Rasterise a thick segment into ``mat`` (vectorised over sample points)."""
    n = int(max(abs(p1[0] - p0[0]), abs(p1[1] - p0[1])) * 2) + 2
    t = np.linspace(0.0, 1.0, n)[:, None]
    pts = (1 - t) * np.asarray(p0, float) + t * np.asarray(p1, float)
    r = int(np.ceil(width / 2))
    off = np.arange(-r, r + 1)
    rows = np.clip(np.rint(pts[:, :1] + off[None, :] * 0).astype(int), 0, TH - 1)
    cols = np.clip(np.rint(pts[:, 1:] + off[None, :]).astype(int), 0, TW - 1)
    mat[np.broadcast_to(rows, cols.shape), cols] = material


def _deciduous(rng: np.random.Generator, cond: Condition, leaves: int):
    mat = np.full((TH, TW), TRANSPARENT, np.uint8)
    yy, xx = np.mgrid[0:TH, 0:TW].astype(np.float32)
    trunk_top = TH * rng.uniform(0.45, 0.6)
    trunk_w = TW * rng.uniform(0.07, 0.1)
    cx = TW / 2
    # Branches: the winter silhouette, drawn first so leaves cover them.
    _line(mat, (TH - 1, cx), (trunk_top, cx), trunk_w, M["trunk"])
    for _ in range(int(rng.integers(5, 9))):
        y0 = trunk_top + rng.uniform(-4, 10)
        ang = rng.uniform(-1.2, 1.2)
        length = TH * rng.uniform(0.25, 0.42)
        y1 = max(3.0, y0 - length * np.cos(ang))
        x1 = float(np.clip(cx + length * np.sin(ang) * 1.1, 3, TW - 4))
        _line(mat, (y0, cx), (y1, x1), max(1.5, trunk_w * 0.45), M["trunk"])
        for _ in range(2):
            t = rng.uniform(0.4, 0.8)
            ya, xa = y0 + t * (y1 - y0), cx + t * (x1 - cx)
            _line(
                mat, (ya, xa), (ya - rng.uniform(6, 16), xa + rng.uniform(-14, 14)), 1, M["trunk"]
            )
    # Crown: a lumpy ellipse made of a few overlapping blobs.
    crown = np.zeros((TH, TW), bool)
    ccy, ry, rx = trunk_top * 0.55, trunk_top * 0.55, TW * 0.46
    for _ in range(6):
        by = ccy + rng.uniform(-0.35, 0.35) * ry
        bx = cx + rng.uniform(-0.45, 0.45) * rx
        r = rng.uniform(0.45, 0.7)
        crown |= ((yy - by) / (ry * r)) ** 2 + ((xx - bx) / (rx * r)) ** 2 < 1.0
    leafy = smooth_noise(rng, (TH, TW), 14)
    shade = 0.75 + 0.45 * leafy + 0.2 * (1 - yy / TH) + 0.1 * (xx / TW)
    if cond.foliage > 0:
        keep = crown & (leafy <= np.quantile(leafy[crown], min(cond.foliage, 1.0)) + 1e-6)
        mat[keep] = leaves
    return mat, shade.astype(np.float32)


def _conifer(rng: np.random.Generator, cond: Condition):
    mat = np.full((TH, TW), TRANSPARENT, np.uint8)
    yy, xx = np.mgrid[0:TH, 0:TW].astype(np.float32)
    cx = TW / 2
    trunk_h = TH * rng.uniform(0.08, 0.14)
    _line(mat, (TH - 1, cx), (TH - trunk_h - 4, cx), TW * 0.08, M["trunk"])
    # Tiers of branches: a saw-tooth edge on a triangle.
    top, base = 2.0, TH - trunk_h
    frac = np.clip((yy - top) / (base - top), 0, 1)
    tiers = rng.integers(5, 8)
    saw = 0.55 + 0.45 * ((frac * tiers) % 1.0)
    half = frac * saw * TW * 0.5
    crown = (yy >= top) & (yy < base) & (np.abs(xx - cx) < half)
    mat[crown] = M["conifer"]
    tex = smooth_noise(rng, (TH, TW), 18)
    shade = 0.8 + 0.4 * tex + 0.12 * (xx / TW)
    if cond.snow:
        # Snow settles on the upper edge of each tier.
        snowy = crown & (((frac * tiers) % 1.0) < 0.45) & (tex > 0.35)
        mat[snowy] = M["snowcap"]
    return mat, shade.astype(np.float32)


def _bush(rng: np.random.Generator, cond: Condition, material: int):
    mat = np.full((TH, TW), TRANSPARENT, np.uint8)
    yy, xx = np.mgrid[0:TH, 0:TW].astype(np.float32)
    body = np.zeros((TH, TW), bool)
    for _ in range(5):
        by = TH * rng.uniform(0.45, 0.75)
        bx = TW * rng.uniform(0.25, 0.75)
        r = rng.uniform(0.3, 0.5)
        body |= ((yy - by) / (TH * r)) ** 2 + ((xx - bx) / (TW * r * 0.9)) ** 2 < 1.0
    body &= yy < TH
    tex = smooth_noise(rng, (TH, TW), 12)
    mat[body] = material
    shade = 0.75 + 0.45 * tex + 0.15 * (1 - yy / TH)
    return mat, shade.astype(np.float32)


def _pole(kind: int):
    mat = np.full((TH, TW), TRANSPARENT, np.uint8)
    cx = TW // 2
    if kind == LAMP_POLE:
        # A thin pole at the right of the box with an arm over the road (to the left).
        mat[6:, cx + 34 : cx + 40] = M["pole"]
        mat[4:9, 8 : cx + 40] = M["pole"]
        mat[8:14, 4:22] = M["lamp"]
    else:
        mat[:, cx - 4 : cx + 4] = M["pole"]
        mat[10:15, cx - 40 : cx + 40] = M["pole"]
        mat[22:26, cx - 28 : cx + 28] = M["pole"]
    shade = np.ones((TH, TW), np.float32)
    shade[:, : TW // 2] = 0.85
    return mat, shade


def make_templates(seed: int, cond: Condition) -> tuple[np.ndarray, np.ndarray]:
    """Return ``(materials, shades)``, shapes (N_TEMPLATES, TH, TW), for one condition.

    Geometry comes from ``seed`` alone, so the same tree has the same shape in every
    condition; only leaves and snow change.
    """
    mats = np.empty((N_TEMPLATES, TH, TW), np.uint8)
    shades = np.empty((N_TEMPLATES, TH, TW), np.float32)
    for k in range(N_TEMPLATES):
        rng = np.random.default_rng([seed, 0x7EE, k])
        if k in DECIDUOUS:
            leaves = M["leaves0"] if k % 2 == 0 else M["leaves1"]
            m, s = _deciduous(rng, cond, leaves)
        elif k in CONIFER:
            m, s = _conifer(rng, cond)
        elif k in BUSH:
            m, s = _bush(rng, cond, M["bush"])
        elif k in (LAMP_POLE, UTILITY_POLE):
            m, s = _pole(k)
        else:  # pragma: no cover - every index is listed above
            raise AssertionError(k)
        mats[k], shades[k] = m, s
    return mats, shades
