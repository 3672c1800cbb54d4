"""Rendering a route that turns and climbs: the straight renderer, bent per depth.

:class:`CurvedRenderer` draws the same world as :class:`~.render.Renderer` but moves every
point ``u`` metres ahead sideways by the route's bend between the camera and ``u`` (see
:mod:`.path`), and the horizon up or down by the camera's pitch. The ground is still one
depth per row (moved sideways per row), a road-parallel plane is found per column by
interpolating its projected columns over sampled depths, and sprites and end walls are
moved as a whole. A straight route never uses this class, so its frames keep their bytes.
"""

from __future__ import annotations

import math

import numpy as np

from ppaloc.datasets.synthetic.conditions import M
from ppaloc.datasets.synthetic.path import RoutePath
from ppaloc.datasets.synthetic.render import (
    GROUND_HALF,
    LAMP_HEIGHT,
    Z_FAR,
    Z_NEAR,
    Renderer,
)
from ppaloc.datasets.synthetic.sprites import TH, TRANSPARENT, TW

__all__ = ["CurvedRenderer"]

DU = 0.5
"""Depth step (m) of the per-frame bend profile."""

_STEPS = np.arange(40, dtype=np.float64)


def _geomspace40(za: float, zb: float) -> np.ndarray:
    """``np.geomspace(za, zb, 40)`` for positive scalars, bit for bit, without its checks
    and promotions (a tenth of the time: it runs for every wall of every frame)."""
    ls, le = np.log10(za), np.log10(zb)
    y = _STEPS * ((le - ls) / 39)
    y += ls
    y[-1] = le
    z = np.power(10.0, y)
    z[0], z[-1] = za, zb
    return z


class CurvedRenderer(Renderer):
    """A :class:`Renderer` for a route with turns (yaw) and hills (pitch).

    Parameters
    ----------
    world, cond, size, colour, seed
        As for :class:`Renderer`.
    path : RoutePath
        The route's heading and pitch.
    height : float
        Camera height (m).
    z_far : float
        Objects further than this are not drawn (m).
    """

    def __init__(
        self,
        world,
        cond,
        size: int = 256,
        colour: bool = False,
        seed: int = 0,
        *,
        path: RoutePath,
        height: float = 1.6,
        z_far: float = Z_FAR,
    ) -> None:
        super().__init__(world, cond, size, colour, seed)
        self.path, self.h, self.z_far = path, float(height), float(z_far)
        self.cy0 = self.cy
        margin = 0.05 * self.f
        self.cy = self.cy0 + margin  # a taller sky, for a camera looking up
        self.sky = self._make_sky(np.random.default_rng([world.seed, 0xC1, seed]))
        self._u = np.arange(0.0, self.z_far + 4 * DU, DU)
        self._lc = np.zeros_like(self._u)
        self._hshift = 0
        self._cache: dict[int, tuple] = {}
        self._set_horizon(self.cy0)

    def _set_horizon(self, cy: float) -> None:
        key = round(cy * 4)
        if key not in self._cache:
            cy = key / 4
            g0 = int(np.searchsorted(self.ys, cy + 0.5))
            z_row = (self.f * self.h / (self.ys[g0:] - cy)).astype(np.float32)
            xrel = ((self.xs - self.cx)[None, :] * z_row[:, None] / self.f).astype(np.float32)
            gain = (0.25 * np.clip(6.0 / z_row, 0.1, 1.0))[:, None].astype(np.float32)
            row_up = ((cy - self.ys)[:, None] / self.f).astype(np.float32)
            self._cache[key] = (cy, g0, z_row, xrel, gain, row_up)
        self.cy, self.g0, self.z_row, self.xrel, self.tex_gain, self.row_up = self._cache[key]

    def lateral(self, z):
        """Sideways bend (m) of the route at depths ``z`` (m) ahead of the camera."""
        return np.interp(z, self._u, self._lc)

    def render(
        self, s_cam: float, x_cam: float, key: tuple[int, ...] = (), yaw: float = 0.0
    ) -> np.ndarray:
        """The frame from route position ``s_cam``, lateral ``x_cam``, turned by ``yaw`` (rad).

        ``yaw`` is the camera's heading relative to the route's (positive: to the right).
        """
        th0 = float(self.path.heading_at(s_cam))
        delta = self.path.heading_at(s_cam + self._u) - th0 - yaw
        sin = np.sin(delta)
        self._lc = np.concatenate([[0.0], np.cumsum((sin[1:] + sin[:-1]) * (0.5 * DU))])
        self._hshift = round(self.f * (th0 + yaw))
        self._set_horizon(self.cy0 + self.f * math.tan(self.path.pitch_at(s_cam)))
        return super().render(s_cam, x_cam, key)

    # ------------------------------------------------------------------ geometry
    def _hills(self, mat, depth, s_cam):
        S = self.S
        shift = (int(s_cam * 0.04) + self._hshift) % (3 * S)
        prof = self.hill[shift : shift + S]
        top = self.cy - S * (0.015 + 0.07 * prof)
        m = self.ys[:, None] >= top[None, :]
        m[self.g0 :] = False
        mat[m] = M["hill"]
        depth[m] = 2500.0

    def _ground(self, mat, shade, depth, s_cam, x_cam):
        sw = self.z_row.astype(np.float64) + s_cam
        off = (x_cam + GROUND_HALF) - self.lateral(self.z_row)
        b = self.xrel + off.astype(np.float32)[:, None]
        self._paint_ground(mat, shade, depth, sw, b)

    def _columns(self, dx: float, za: float, zb: float):
        """Columns and depths of a road-parallel plane at ``dx`` over depths [za, zb], bent."""
        if zb <= za:
            return None
        z = _geomspace40(za, zb)
        c = self.cx + self.f * (dx + self.lateral(z)) / z
        d = np.diff(c)
        flips = np.flatnonzero(np.sign(d) != np.sign(d[0]))
        if flips.size:  # the plane turns away: its far part is hidden behind its near part
            z, c = z[: flips[0] + 1], c[: flips[0] + 1]
        if c.size < 2:
            return None
        if c[0] > c[-1]:
            z, c = z[::-1], c[::-1]
        c0 = max(int(np.ceil(c[0] - 0.5)), 0)
        c1 = min(int(np.floor(c[-1] - 0.5)) + 1, self.S)
        if c1 <= c0:
            return None
        return c0, c1, np.interp(self.xs[c0:c1], c, z).astype(np.float32)

    def _boxes(self, mat, shade, depth, s_cam, x_cam):
        b = self.world.boxes
        i0 = int(np.searchsorted(b.s0, s_cam - self._box_reach))
        i1 = int(np.searchsorted(b.s0, s_cam + self.z_far))
        for i in range(i0, i1):
            if b.s1[i] <= s_cam + Z_NEAR:
                continue
            self._facade(mat, shade, depth, s_cam, x_cam, i)
            if b.s0[i] - s_cam > Z_NEAR:
                self._end_wall(mat, shade, depth, s_cam, x_cam, i)

    def _end_wall(self, mat, shade, depth, s_cam, x_cam, i):
        z = float(self.world.boxes.s0[i] - s_cam)
        super()._end_wall(mat, shade, depth, s_cam, x_cam - float(self.lateral(z)), i)

    def _sprites(self, mat, shade, depth, s_cam, x_cam):
        sp = self.world.sprites
        i0 = int(np.searchsorted(sp.s, s_cam + Z_NEAR))
        i1 = int(np.searchsorted(sp.s, s_cam + self.z_far))
        f, S, cx, cy, h = self.f, self.S, self.cx, self.cy, self.h
        if i1 <= i0:
            return
        s_in, x_in, w_in, h_in, k_in = self._sprite_window(i0, i1)
        shifts = self.lateral(np.asarray(s_in) - s_cam).tolist()
        for i in range(i0, i1):
            j = i - i0
            z = s_in[j] - s_cam
            w_px = f * w_in[j] / z
            if w_px < 1.5:
                continue
            xc = cx + f * (x_in[j] - x_cam + shifts[j]) / z
            yb = cy + f * h / z
            yt = cy - f * (h_in[j] - h) / z
            xl = xc - w_px / 2
            c0, c1 = max(int(xl), 0), min(math.ceil(xc + w_px / 2), S)
            r0, r1 = max(int(yt), 0), min(math.ceil(yb), S)
            if c0 >= c1 or r0 >= r1:
                continue
            region = depth[r0:r1, c0:c1]
            zf = np.float32(z)
            if zf >= region.max():
                continue
            ti = ((self.ys[r0:r1] - np.float32(yt)) * np.float32(TH / (yb - yt))).astype(np.intp)
            tj = ((self.xs[c0:c1] - np.float32(xl)) * np.float32(TW / w_px)).astype(np.intp)
            np.clip(ti, 0, TH - 1, out=ti)
            np.clip(tj, 0, TW - 1, out=tj)
            k = k_in[j]
            if i % 2 and k < 7:
                tj = TW - 1 - tj
            m = self.tmat[k][ti[:, None], tj[None, :]]
            ok = (m != TRANSPARENT) & (zf < region)
            if ok.any():
                sh = self.tshade[k][ti[:, None], tj[None, :]]
                self._write(mat, shade, depth, r0, r1, c0, c1, ok, m, sh, zf)

    def _glow(self, out, s_cam, x_cam):
        lamps = self.world.lamps
        j0, j1 = np.searchsorted(lamps[:, 0], [s_cam + 2, s_cam + self.z_far])
        for s_l, x_l in lamps[j0:j1]:
            z = s_l - s_cam
            xc = self.cx + self.f * (x_l - x_cam + float(self.lateral(z))) / z
            yc = self.cy - self.f * (LAMP_HEIGHT - self.h) / z
            r = max(self.f * 1.3 / z, 1.5)
            c0, c1 = max(int(xc - 3 * r), 0), min(int(xc + 3 * r) + 1, self.S)
            r0, r1 = max(int(yc - 3 * r), 0), min(int(yc + 3 * r) + 1, self.S)
            if c0 >= c1 or r0 >= r1:
                continue
            d2 = (self.ys[r0:r1, None] - yc) ** 2 + (self.xs[None, c0:c1] - xc) ** 2
            blob = 170.0 * np.exp(-d2 / (r * r))
            out[r0:r1, c0:c1] += blob if self.C == 1 else blob[..., None]
