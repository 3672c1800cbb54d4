"""Perspective rendering of the world with numpy (no per-pixel Python loops).

A pinhole camera ``CAMERA_HEIGHT`` metres above the road looks along the road (+s). A
world point ``(s, x, y)`` seen from the camera at ``(s_cam, x_cam)`` lands at column
``cx + f (x - x_cam) / z`` and row ``cy - f (y - h) / z`` with depth ``z = s - s_cam``.
So everything flows outwards from the vanishing point ``(cx, cy)`` as the camera moves
forward, which is the cue the paper's motion model uses.

The frame is built in two passes:

1. *Geometry* (same for every condition): per pixel a material id, a shading factor and a
   depth, filled by z-buffer. The ground is solved per row (a row of the ground plane is one
   depth); planes parallel to the road (facades, fences, hedges, forest edges) per column
   (a column of such a plane is one depth); trees, bushes and poles are camera-facing
   sprites sampled from templates.
2. *Appearance* (per condition): palette lookup, light (sun side, or at night headlights,
   street-lamp pools and lit windows), sky with clouds, fog by depth, falling snow,
   brightness and contrast, vignetting and sensor noise.
"""

from __future__ import annotations

import math

import numpy as np

from ppaloc.datasets.synthetic.conditions import EMISSIVE, Condition, M
from ppaloc.datasets.synthetic.sprites import TH, TRANSPARENT, TW, make_templates, smooth_noise
from ppaloc.datasets.synthetic.world import FOREST, ROAD_HALF, SEGMENT_TYPES, SUBURB, TOWN, World

__all__ = ["CAMERA_HEIGHT", "LANE_CENTRE", "Renderer"]

CAMERA_HEIGHT = 1.6
"""Camera height over the road (m)."""

LANE_CENTRE = ROAD_HALF / 2
"""Lateral position of the right lane's centre (m)."""

LAMP_HEIGHT = 6.4
"""Height of a street lamp's head (m)."""

GROUND_BINS, GROUND_HALF = 48, 80
"""Lateral resolution (bins per metre) and half-width (m) of the ground profiles."""

Z_NEAR, Z_FAR = 1.0, 170.0
"""Objects are drawn between these depths (m); fog hides the far end."""

_LUMA = np.array([0.299, 0.587, 0.114], np.float32)


class Renderer:
    """Renders frames of one world under one condition.

    Parameters
    ----------
    world : World
    cond : Condition
    size : int
        Frame side in pixels (square frames).
    colour : bool
        Render RGB (H, W, 3) instead of grey (H, W).
    seed : int
        Seeds the clouds and the sensor noise bank of this traversal.

    Notes
    -----
    Set-up (templates, sky, noise bank) costs a few tens of milliseconds; each
    :meth:`render` call is independent of the calls before it, so frames can be rendered in
    any order and give the same bytes.
    """

    def __init__(
        self, world: World, cond: Condition, size: int = 256, colour: bool = False, seed: int = 0
    ) -> None:
        self.world, self.cond, self.S = world, cond, int(size)
        S = self.S
        self.f = 0.6 * S
        self.cx, self.cy = S / 2.0, 0.47 * S
        self.h = CAMERA_HEIGHT
        self.xs = np.arange(S, dtype=np.float32) + 0.5
        self.ys = np.arange(S, dtype=np.float32) + 0.5
        rgb = cond.rgb_lut()
        self.lut = rgb if colour else (rgb @ _LUMA).astype(np.float32)
        self.C = 3 if colour else 1
        fog = np.asarray(cond.fog_colour, np.float32)
        self.fog = fog if colour else np.float32(fog @ _LUMA)
        rng = np.random.default_rng([world.seed, 0xC0, seed])

        # Ground: every row below the horizon is one depth.
        self.g0 = int(np.searchsorted(self.ys, self.cy + 0.5))
        self.z_row = (self.f * self.h / (self.ys[self.g0 :] - self.cy)).astype(np.float32)
        self.xrel = ((self.xs - self.cx)[None, :] * self.z_row[:, None] / self.f).astype(np.float32)
        ground_rng = np.random.default_rng([world.seed, 0x6D])
        self.tex = (smooth_noise(ground_rng, (512, 512), 90) * 2 - 1).astype(np.float32)
        self.tex_gain = (0.25 * np.clip(6.0 / self.z_row, 0.1, 1.0))[:, None].astype(np.float32)
        self.ground_mat, self.ground_shade, self.ground_centre = self._ground_luts()
        self.self_lit = np.zeros(256, bool)  # materials that keep their colour at night
        self.self_lit[[*EMISSIVE, M["sky"]]] = True

        # Background: sky above the horizon, distant hills on it.
        self.hill = smooth_noise(np.random.default_rng([world.seed, 0x41]), (1, 4 * S), 10)[0]
        self.sky = self._make_sky(rng)
        self.tmat, self.tshade = make_templates(world.seed, cond)
        yy, xx = np.mgrid[0:S, 0:S].astype(np.float32)
        r2 = ((yy - S / 2) ** 2 + (xx - S / 2) ** 2) / (S / 2) ** 2
        self.vignette = (1.0 - 0.12 * r2).astype(np.float32)
        self.noise_bank = rng.standard_normal(S * S * 2, dtype=np.float32)
        self.noise_bank *= np.float32(cond.noise_sigma)
        self.beam_night = (1.3 * np.exp(-(((self.xs - self.cx) / (0.28 * S)) ** 2))).astype(
            np.float32
        )
        self.row_up = ((self.cy - self.ys)[:, None] / self.f).astype(np.float32)
        self._plane_reach = float(np.max(world.planes.s1 - world.planes.s0, initial=0.0))
        self._box_reach = float(np.max(world.boxes.s1 - world.boxes.s0, initial=0.0))

    def _sprite_window(self, i0: int, i1: int) -> tuple[list, list, list, list, list]:
        """Sprites ``i0 .. i1 - 1`` (the ones in view) as Python lists (s, x, width, height,
        template) for the scalar loop: made per frame for the few in view, so a long route
        keeps its sprites in the world's arrays only."""
        sp = self.world.sprites
        cut = slice(i0, i1)
        return (
            sp.s[cut].tolist(), sp.x[cut].tolist(), sp.width[cut].tolist(),
            sp.height[cut].tolist(), sp.template[cut].tolist(),
        )  # fmt: skip

    # ------------------------------------------------------------------ set-up helpers
    def _make_sky(self, rng: np.random.Generator) -> np.ndarray:
        cond, S = self.cond, self.S
        rows = int(np.ceil(self.cy)) + 1
        t = np.clip(self.ys[:rows] / self.cy, 0, 1)[:, None, None] ** 0.8
        top = np.asarray(cond.sky_top, np.float32)
        hor = np.asarray(cond.sky_horizon, np.float32)
        grad = top * (1 - t) + hor * t  # (rows, 1, 3)
        n = smooth_noise(rng, (rows, 3 * S), 14)
        n2 = smooth_noise(rng, (rows, 3 * S), 40)
        cover = np.clip((n - (1 - cond.cloud_cover)) / 0.22, 0, 1)
        cover *= np.clip(1.2 - t[:, :, 0], 0, 1)  # clouds thin out toward the horizon
        cloud = np.asarray(cond.cloud_colour, np.float32) * (0.8 + 0.25 * n2)[..., None]
        sky = grad * (1 - cover[..., None]) + cloud * cover[..., None]
        if cond.night and cond.ambient < 0.3:
            stars = rng.random((rows, 3 * S)) > 0.997
            sky[stars] = 120.0
        if self.C == 1:
            return (sky @ _LUMA).astype(np.float32)
        return sky.astype(np.float32)

    # ------------------------------------------------------------------ public API
    def render(self, s_cam: float, x_cam: float, key: tuple[int, ...] = ()) -> np.ndarray:
        """Return the frame seen from route position ``s_cam`` (m), lateral ``x_cam`` (m).

        ``key`` seeds what changes from frame to frame (snowflakes, sensor noise). Output is
        ``uint8``, shape (S, S) grey or (S, S, 3) colour.
        """
        mat, shade, depth = self.geometry(s_cam, x_cam)
        return self.appearance(mat, shade, depth, s_cam, x_cam, key)

    # ------------------------------------------------------------------ geometry
    def geometry(self, s_cam: float, x_cam: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Material ids (``uint8``), shading and depth (m; ``inf`` for sky), each (S, S)."""
        S = self.S
        mat = np.full((S, S), M["sky"], np.uint8)
        shade = np.ones((S, S), np.float32)
        depth = np.full((S, S), np.inf, np.float32)
        self._hills(mat, depth, s_cam)
        self._ground(mat, shade, depth, s_cam, x_cam)
        self._boxes(mat, shade, depth, s_cam, x_cam)
        self._planes(mat, shade, depth, s_cam, x_cam)
        self._sprites(mat, shade, depth, s_cam, x_cam)
        return mat, shade, depth

    def _hills(self, mat, depth, s_cam):
        S = self.S
        shift = int(s_cam * 0.04) % (3 * S)
        prof = self.hill[shift : shift + S]
        top = self.cy - S * (0.015 + 0.07 * prof)
        m = self.ys[:, None] >= top[None, :]
        m[self.g0 :] = False
        mat[m] = M["hill"]
        depth[m] = 2500.0

    def _ground_luts(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Across-the-road profiles, one per kind of surroundings, in ``GROUND_BINS`` per metre.

        ``mat[t, b]`` and ``shade[t, b]`` are the material and shading at lateral bin ``b``
        (``x = b / GROUND_BINS - GROUND_HALF``) next to surroundings of kind ``t``; ``centre[b]``
        marks the centre line (dashed per row). Lanes, edge lines, wheel tracks, kerbs,
        pavements and verges are all functions of ``x`` alone, so the ground costs one lookup
        per pixel instead of a chain of comparisons.
        """
        x = (np.arange(2 * GROUND_HALF * GROUND_BINS) + 0.5) / GROUND_BINS - GROUND_HALF
        ax = np.abs(x)
        mats, shades = [], []
        for t in range(len(SEGMENT_TYPES)):
            built = t in (TOWN, SUBURB)
            side_w = {TOWN: 4.5, SUBURB: 2.2}.get(t, 1.4)
            side_m = M["sidewalk"] if built else M["verge"]
            far_m = {TOWN: M["sidewalk"], FOREST: M["verge"]}.get(t, M["field"])
            m = np.where(
                ax < ROAD_HALF, M["road"], np.where(ax < ROAD_HALF + side_w, side_m, far_m)
            )
            m[np.abs(ax - (ROAD_HALF - 0.25)) < 0.08] = M["marking"]
            sh = np.ones_like(x)
            tracks = (np.abs(np.abs(ax - LANE_CENTRE) - 0.85) < 0.3) & (ax < ROAD_HALF)
            sh[tracks] = 0.94  # darker wheel tracks in each lane
            if built:
                sh[np.abs(ax - ROAD_HALF) < 0.12] = 0.75  # kerb
            mats.append(m.astype(np.uint8))
            shades.append(sh.astype(np.float32))
        return np.stack(mats), np.stack(shades), ax < 0.09

    def _ground(self, mat, shade, depth, s_cam, x_cam):
        sw = self.z_row.astype(np.float64) + s_cam
        b = self.xrel + np.float32(x_cam + GROUND_HALF)
        self._paint_ground(mat, shade, depth, sw, b)

    def _ground_extra(self, m: np.ndarray, sw: np.ndarray, x: np.ndarray) -> None:
        """Hook: extra ground markings per row ``sw`` (m along) and bin ``x`` (none here)."""

    def _paint_ground(self, mat, shade, depth, sw, b) -> None:
        """Fill the ground rows from ``b``, metres across from the ground's left edge.

        ``sw`` is each ground row's distance along the route (m); ``b`` (float32, rows x
        columns) is scaled in place to profile bins.
        """
        g = slice(self.g0, self.S)
        width = self.ground_mat.shape[1]
        b *= np.float32(GROUND_BINS)
        xb = b.astype(np.intp)
        np.clip(xb, 0, width - 1, out=xb)
        row = (self.world.segment_at(sw) * width)[:, None]  # which profile, per row
        flat = xb + row
        m = np.take(self.ground_mat, flat)
        dash_rows = ((sw % 9.0) < 3.0)[:, None]
        m[np.take(self.ground_centre, xb) & dash_rows] = M["marking"]
        self._ground_extra(m, sw, xb)
        # World-fixed texture (12 texels per metre), fading with distance to avoid shimmer.
        ti = ((np.floor(sw * 12.0).astype(np.intp) & 511) * 512)[:, None]
        tj = (xb >> 2) & 511
        tj += ti
        sh = np.take(self.tex, tj)
        sh *= self.tex_gain
        sh += np.float32(1.0)
        sh *= np.take(self.ground_shade, flat)
        mat[g] = m
        shade[g] = sh
        depth[g] = self.z_row[:, None]

    def _columns(self, dx: float, za: float, zb: float):
        """Columns where a road-parallel plane at lateral ``dx`` spans depths [za, zb]."""
        if abs(dx) < 0.2 or zb <= za:
            return None
        xa = self.cx + self.f * dx / za
        xb = self.cx + self.f * dx / zb
        lo, hi = min(xa, xb), max(xa, xb)
        c0 = max(int(np.ceil(lo - 0.5)), 0)
        c1 = min(int(np.floor(hi - 0.5)) + 1, self.S)
        if c1 <= c0:
            return None
        z = self.f * dx / (self.xs[c0:c1] - self.cx)
        ok = (z >= za) & (z <= zb)
        if not ok.any():
            return None
        idx = np.flatnonzero(ok)
        c0, c1 = c0 + int(idx[0]), c0 + int(idx[-1]) + 1
        return c0, c1, z[idx[0] : idx[-1] + 1]

    def _rows(self, z: np.ndarray, top: np.ndarray):
        """Row window and per-pixel world height for a plane of depths ``z`` up to ``top``."""
        y_top = self.cy - self.f * (top - self.h) / z
        y_bot = self.cy + self.f * self.h / z
        r0 = max(int(np.floor(float(y_top.min()))), 0)
        r1 = min(int(np.ceil(float(y_bot.max()))), self.S)
        if r1 <= r0:
            return None
        v = self.h + (self.cy - self.ys[r0:r1, None]) * z[None, :] / self.f
        return r0, r1, v

    @staticmethod
    def _write(mat, shade, depth, r0, r1, c0, c1, ok, m, sh, z):
        np.copyto(mat[r0:r1, c0:c1], m.astype(np.uint8, copy=False), where=ok)
        np.copyto(shade[r0:r1, c0:c1], sh, where=ok)
        np.copyto(depth[r0:r1, c0:c1], z, where=ok)

    def _boxes(self, mat, shade, depth, s_cam, x_cam):
        b = self.world.boxes
        i0 = int(np.searchsorted(b.s0, s_cam - self._box_reach))
        i1 = int(np.searchsorted(b.s0, s_cam + Z_FAR))
        for i in range(i0, i1):
            if b.s1[i] <= s_cam + Z_NEAR:
                continue
            self._facade(mat, shade, depth, s_cam, x_cam, i)
            if b.s0[i] - s_cam > Z_NEAR:
                self._end_wall(mat, shade, depth, s_cam, x_cam, i)

    def _windows(self, i: int, u: np.ndarray, v: np.ndarray, wall_h: float) -> np.ndarray:
        """Material of facade points at ``u`` (along, shape (1, C)) and ``v`` (up, (R, C)) m.

        Wall, window (a lit window at night, by a per-building hash of column and floor),
        a shop window band on some town ground floors, and a door every few columns.
        """
        b = self.world.boxes
        wx, wy = b.win_dx[i], b.win_dy[i]
        ident = int(b.ident[i])
        col = np.floor(u / wx)
        fu = u / wx - col
        in_col = np.abs(fu - 0.5) < b.win_w[i] / 2
        door_col = (np.abs(fu - 0.5) < 0.18) & ((col + ident) % 5 == 2)
        vv = v / wy
        row = np.floor(vv)
        fv = vv - row
        m = np.full(v.shape, M["wall0"] + int(b.colour[i]), np.uint8)
        win = in_col & (fv > 0.3) & (fv < 0.82) & (v > 1.0) & (v < wall_h - 0.5)
        lit = ((col.astype(np.int64) * 7919 + row.astype(np.int64) * 104729 + ident) % 7) < 3
        m[win] = M["window"]
        m[win & lit] = M["window_lit"]
        if wall_h > 6.5 and ident % 3 == 0:  # a shop: a wide window band on the ground floor
            m[(v > 0.5) & (v < 2.6) & (np.abs(fu - 0.5) < 0.42)] = M["window_lit"]
            m[(v >= 2.6) & (v < 3.2)] = M["door"]
        m[door_col & (v < 2.3)] = M["door"]
        return m

    def _facade(self, mat, shade, depth, s_cam, x_cam, i):
        b = self.world.boxes
        dx = b.x[i] - x_cam
        cols = self._columns(dx, max(b.s0[i] - s_cam, Z_NEAR), min(b.s1[i] - s_cam, Z_FAR))
        if cols is None:
            return
        c0, c1, z = cols
        u = s_cam + z - b.s0[i]
        H, roof = b.height[i], b.roof[i]
        top = H + roof * 0.6 * np.clip(np.minimum(u, b.s1[i] - b.s0[i] - u) / max(roof, 0.1), 0, 1)
        rows = self._rows(z, top)
        if rows is None:
            return
        r0, r1, v = rows
        ok = (v >= 0) & (v < top[None, :]) & (z[None, :] < depth[r0:r1, c0:c1])
        if not ok.any():
            return
        m = np.where(v >= H, M["roof"], self._windows(i, u[None, :], v, H))
        sh = np.float32(1.08 if dx < 0 else 0.9)
        self._write(mat, shade, depth, r0, r1, c0, c1, ok, m, sh, z[None, :])

    def _end_wall(self, mat, shade, depth, s_cam, x_cam, i):
        b = self.world.boxes
        z = float(b.s0[i] - s_cam)
        if z > Z_FAR:
            return
        xa = b.x[i]
        xb = xa + np.sign(xa) * b.depth[i]
        ca = self.cx + self.f * (xa - x_cam) / z
        cb = self.cx + self.f * (xb - x_cam) / z
        c0 = max(int(np.ceil(min(ca, cb) - 0.5)), 0)
        c1 = min(int(np.floor(max(ca, cb) - 0.5)) + 1, self.S)
        if c1 <= c0:
            return
        lat = np.abs(x_cam + (self.xs[c0:c1] - self.cx) * z / self.f - xa)
        H, roof, D = b.height[i], b.roof[i], b.depth[i]
        top = H + roof * np.clip(1 - np.abs(2 * lat / D - 1), 0, 1)
        zz = np.full(c1 - c0, z, np.float32)
        rows = self._rows(zz, top)
        if rows is None:
            return
        r0, r1, v = rows
        ok = (v >= 0) & (v < top[None, :]) & (z < depth[r0:r1, c0:c1])
        if not ok.any():
            return
        m = np.where(v >= H, M["wall0"] + int(b.colour[i]), self._windows(i, lat[None, :], v, H))
        self._write(mat, shade, depth, r0, r1, c0, c1, ok, m, np.float32(0.75), np.float32(z))

    def _planes(self, mat, shade, depth, s_cam, x_cam):
        p = self.world.planes
        i0 = int(np.searchsorted(p.s0, s_cam - self._plane_reach))
        i1 = int(np.searchsorted(p.s0, s_cam + Z_FAR))
        for i in range(i0, i1):
            if p.s1[i] <= s_cam + Z_NEAR:
                continue
            dx = p.x[i] - x_cam
            cols = self._columns(dx, max(p.s0[i] - s_cam, Z_NEAR), min(p.s1[i] - s_cam, Z_FAR))
            if cols is None:
                continue
            c0, c1, z = cols
            u = (s_cam + z).astype(np.float64)
            kind = int(p.kind[i])
            tu = np.floor(u * 2.0).astype(np.int64) & 511
            if kind == 0:  # fence: posts every 2.5 m and two rails
                top = np.full_like(z, p.height[i])
            elif kind == 1:  # hedge with a ragged top
                top = p.height[i] * (0.85 + 0.3 * (self.tex[7, tu] * 0.5 + 0.5))
            else:  # forest edge: a line of crowns
                crowns = 0.5 + 0.5 * np.sin(u * 0.9 + 3 * self.tex[11, tu])
                top = p.height[i] * (0.7 + 0.35 * crowns)
            rows = self._rows(z, top)
            if rows is None:
                continue
            r0, r1, v = rows
            ok = (v >= 0) & (v < top[None, :]) & (z[None, :] < depth[r0:r1, c0:c1])
            if kind == 0:
                post = ((u % 2.5) < 0.14)[None, :]
                rail = (np.abs(v - 0.45) < 0.06) | (np.abs(v - 1.05) < 0.07)
                ok &= post | rail
                m, sh = np.full(ok.shape, M["fence"]), np.float32(1.0)
            else:
                tv = np.floor(np.clip(v, 0, 60) * 3.0).astype(np.int64) & 511
                sh = (0.7 + 0.45 * (self.tex[tv, tu[None, :]] * 0.5 + 0.5)).astype(np.float32)
                if kind == 1:
                    m = np.full(ok.shape, M["hedge"])
                else:
                    trunks = ((u * 1.3) % 1.0 < 0.18)[None, :] & (v < 3.5)
                    m = np.where(trunks, M["trunk"], M["forest"])
            if ok.any():
                self._write(mat, shade, depth, r0, r1, c0, c1, ok, m, sh, z[None, :])

    def _sprites(self, mat, shade, depth, s_cam, x_cam):
        sp = self.world.sprites
        i0 = int(np.searchsorted(sp.s, s_cam + Z_NEAR))
        i1 = int(np.searchsorted(sp.s, s_cam + Z_FAR))
        f, S, cx, cy, h = self.f, self.S, self.cx, self.cy, self.h
        s_in, x_in, w_in, h_in, k_in = self._sprite_window(i0, i1)
        for i in range(i0, i1):
            j = i - i0
            z = s_in[j] - s_cam
            w_px = f * w_in[j] / z
            if w_px < 1.5:
                continue
            xc = cx + f * (x_in[j] - x_cam) / z
            yb = cy + f * h / z
            yt = cy - f * (h_in[j] - h) / z
            xl = xc - w_px / 2
            c0, c1 = max(int(xl), 0), min(math.ceil(xc + w_px / 2), S)
            r0, r1 = max(int(yt), 0), min(math.ceil(yb), S)
            if c0 >= c1 or r0 >= r1:
                continue
            region = depth[r0:r1, c0:c1]
            zf = np.float32(z)
            if zf >= region.max():  # hidden behind nearer things already drawn
                continue
            # Pixel centres from the box's top-left corner, scaled to template texels.
            ti = ((self.ys[r0:r1] - np.float32(yt)) * np.float32(TH / (yb - yt))).astype(np.intp)
            tj = ((self.xs[c0:c1] - np.float32(xl)) * np.float32(TW / w_px)).astype(np.intp)
            np.maximum(ti, 0, out=ti)
            np.minimum(ti, TH - 1, out=ti)
            np.maximum(tj, 0, out=tj)
            np.minimum(tj, TW - 1, out=tj)
            k = k_in[j]
            if i % 2 and k < 7:  # mirror every other tree: more variety
                tj = TW - 1 - tj
            m = self.tmat[k][ti[:, None], tj[None, :]]
            ok = (m != TRANSPARENT) & (zf < region)
            if ok.any():
                sh = self.tshade[k][ti[:, None], tj[None, :]]
                self._write(mat, shade, depth, r0, r1, c0, c1, ok, m, sh, zf)

    # ------------------------------------------------------------------ appearance
    def appearance(self, mat, shade, depth, s_cam, x_cam, key) -> np.ndarray:
        """Turn geometry into a ``uint8`` frame under this renderer's condition."""
        cond, S = self.cond, self.S
        grey = self.C == 1

        def ex(a):  # broadcast a per-pixel factor over the colour channels
            return a if grey else a[..., None]

        sky = mat == M["sky"]
        light = self._night_light(mat, shade, depth, x_cam, s_cam) if cond.night else shade
        out = self.lut[mat]
        out *= ex(light)
        shift = int(s_cam * 0.02) % (2 * S)
        rows = self.sky.shape[0]
        np.copyto(out[:rows], self.sky[:, shift : shift + S], where=ex(sky[:rows]))
        if np.isfinite(cond.fog_distance):
            keep = np.exp(depth * np.float32(-1.0 / cond.fog_distance))
            keep[sky] = 1.0
            out -= self.fog
            out *= ex(keep)
            out += self.fog
        rng = np.random.default_rng([self.world.seed, 0xF4, *key])
        if cond.night:
            self._glow(out, s_cam, x_cam)
        if cond.snowfall:
            self._snow(out, rng)
        if cond.gamma != 1.0:
            out = np.clip(out * np.float32(cond.gain / 255.0) + np.float32(cond.bias), 0, 1)
            out **= np.float32(cond.gamma)
            out *= ex(self.vignette * np.float32(255.0))
            out += 0.5
        else:
            out *= ex(self.vignette * np.float32(cond.gain))
            out += ex(self.vignette * np.float32(255.0 * cond.bias) + np.float32(0.5))
        if cond.noise_sigma:
            o = int(rng.integers(0, S * S))
            n = self.noise_bank[o : o + S * S].reshape(S, S)
            out += ex(n)
        np.clip(out, 0, 255, out=out)
        return out.astype(np.uint8)

    def _night_light(self, mat, shade, depth, x_cam, s_cam):
        """Light at night: a little ambient, the car's headlights, street lamps.

        Each lamp lights every surface within a few metres of it (ground, facades, trees),
        found from the pixel's depth, so lit street corners look the same on every pass.
        """
        f = self.f
        d = np.minimum(depth, np.float32(1e4))
        height = self.row_up * d
        height += np.float32(self.h)
        # Headlights: fade with distance and above the bonnet, a beam across the columns.
        head = np.maximum(height - np.float32(1.0), np.float32(0.0))
        head += d * np.float32(1 / 13.0)
        np.exp(-head, out=head)
        head *= self.beam_night[None, :]
        light = head
        light += np.float32(self.cond.ambient)
        lamps = self.world.lamps
        j0, j1 = np.searchsorted(lamps[:, 0], [s_cam + 1.0, s_cam + 90.0])
        reach = 9.0  # metres a lamp visibly lights
        for s_l, x_l in lamps[j0:j1]:
            z = s_l - s_cam
            zn = max(z - reach, 0.5)
            c0 = max(
                int(
                    self.cx + f * (x_l - reach - x_cam) / (zn if x_l - reach < x_cam else z + reach)
                ),
                0,
            )
            c1 = min(
                int(
                    self.cx + f * (x_l + reach - x_cam) / (zn if x_l + reach > x_cam else z + reach)
                )
                + 2,
                self.S,
            )
            r0 = max(int(self.cy - f * (LAMP_HEIGHT + reach - self.h) / zn), 0)
            r1 = min(int(self.cy + f * self.h / max(z - reach, 0.5)) + 2, self.S)
            if c0 >= c1 or r0 >= r1:
                continue
            dd = d[r0:r1, c0:c1]
            ds = dd - z
            dx = x_cam + (self.xs[c0:c1] - self.cx) * dd / f - x_l
            dy = height[r0:r1, c0:c1] - LAMP_HEIGHT
            light[r0:r1, c0:c1] += 1.1 * np.exp(-(ds * ds + dx * dx + 0.5 * dy * dy) / 30.0)
        light *= shade
        np.copyto(light, np.float32(1.0), where=np.take(self.self_lit, mat))
        return light

    def _glow(self, out, s_cam, x_cam):
        lamps = self.world.lamps
        j0, j1 = np.searchsorted(lamps[:, 0], [s_cam + 2, s_cam + Z_FAR])
        for s_l, x_l in lamps[j0:j1]:
            z = s_l - s_cam
            xc = self.cx + self.f * (x_l - x_cam) / z
            yc = self.cy - self.f * (LAMP_HEIGHT - self.h) / z
            r = max(self.f * 1.3 / z, 1.5)
            c0, c1 = max(int(xc - 3 * r), 0), min(int(xc + 3 * r) + 1, self.S)
            r0, r1 = max(int(yc - 3 * r), 0), min(int(yc + 3 * r) + 1, self.S)
            if c0 >= c1 or r0 >= r1:
                continue
            d2 = (self.ys[r0:r1, None] - yc) ** 2 + (self.xs[None, c0:c1] - xc) ** 2
            blob = 170.0 * np.exp(-d2 / (r * r))
            out[r0:r1, c0:c1] += blob if self.C == 1 else blob[..., None]

    def _snow(self, out, rng):
        S = self.S
        n = int(self.cond.snowfall * (S / 256) ** 2)
        ys = rng.integers(0, S, n)
        xs = rng.integers(0, S, n)
        val = rng.uniform(200, 250, n).astype(np.float32)
        if self.C == 3:
            val = val[:, None]
        out[ys, xs] = np.maximum(out[ys, xs], val)
        big = n // 4
        y2, x2 = np.minimum(ys[:big] + 1, S - 1), np.minimum(xs[:big] + 1, S - 1)
        for yy, xx in ((y2, xs[:big]), (ys[:big], x2), (y2, x2)):
            out[yy, xx] = np.maximum(out[yy, xx], val[:big])
