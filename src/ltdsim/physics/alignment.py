"""The track in the plane: a horizontal alignment of piecewise-linear curvature and cant
(straights, circular arcs, clothoid transitions, reverse curves), its heading and
position integrated along it, and the alignment of a scenario's ``[track]``.

Plain numpy. The curve resistance of the kernel reads the alignment's curvature averaged
in steps (:meth:`Alignment.step_table`), the curving indicators after a run
(:mod:`ltdsim.results.safety`) its geometry. Lengths m, curvature 1/m (+ turning left),
cant m (the outer rail's height over the inner), angles rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# Gauss-Legendre nodes and weights on [0, 1] for the position integral
_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)
_GL_X = 0.5 * (_GL_X + 1.0)
_GL_W = 0.5 * _GL_W


#: m: how far beyond the stretch a run can reach the track is kept (:func:`reach`): more
#: than any vehicle's half length and bogie spacing, and the 50 m :meth:`Alignment.pose`
#: grids beyond the positions it is asked for
REACH_MARGIN = 1000.0


def reach(lo: float, hi: float, travel: float = 0.0) -> tuple[float, float]:
    """The stretch of track, ``(from m, to m)``, a run needs whose vehicle centres lie
    between ``lo`` and ``hi`` (m) and move at most ``travel`` (m) either way: that
    widened by :data:`REACH_MARGIN`. The track tables are used over it only
    (:meth:`Alignment.clipped`), so their memory follows the run, not the tables."""
    return lo - travel - REACH_MARGIN, hi + travel + REACH_MARGIN


@dataclass
class Alignment:
    """Horizontal alignment with piecewise-linear curvature and cant.

    ``s`` holds the knots (m, increasing); on ``[s[k], s[k+1]]`` the curvature runs
    linearly from ``k0[k]`` to ``k1[k]`` (1/m, + left) and the cant from ``h0[k]`` to
    ``h1[k]`` (m). Before the first knot and after the last, curvature and cant keep
    their end values.
    """

    s: np.ndarray
    k0: np.ndarray
    k1: np.ndarray
    h0: np.ndarray
    h1: np.ndarray

    @classmethod
    def from_knots(cls, s, k0, k1, h0, h1) -> Alignment:
        return cls(*(np.asarray(a, dtype=float) for a in (s, k0, k1, h0, h1)))

    def clipped(self, lo: float, hi: float) -> Alignment:
        """The alignment over ``[lo, hi]`` (m) only: the same curvature and cant at every
        chainage in it, its end values held beyond it. Itself when every knot lies in
        ``[lo, hi]``; otherwise the knots inside, and knots at ``lo`` and ``hi`` where they
        cut a piece, so that a table reaching 10,000 km costs only what the stretch
        between ``lo`` and ``hi`` costs (:meth:`step_table`, :meth:`pose`)."""
        s = self.s
        if s[0] >= lo and s[-1] <= hi:
            return self
        if not lo < hi:
            raise ValueError(f"clipped: lo ({lo:g} m) must be below hi ({hi:g} m)")
        a, b = max(lo, float(s[0])), min(hi, float(s[-1]))
        if a >= b:  # [lo, hi] lies beyond one end: there the end values hold
            k = 0 if hi <= s[0] else -1
            kap = self.k0[0] if k == 0 else self.k1[-1]
            h = self.h0[0] if k == 0 else self.h1[-1]
            return Alignment.from_knots([lo, hi], [kap], [kap], [h], [h])
        inner = s[(s > a) & (s < b)]
        knots = np.concatenate(([a], inner, [b]))
        mid = 0.5 * (knots[:-1] + knots[1:])
        piece = np.clip(np.searchsorted(s, mid, side="right") - 1, 0, len(self.k0) - 1)

        def on_piece(v0, v1, x):  # the value of the original piece at x
            t = (x - s[piece]) / (s[piece + 1] - s[piece])
            return v0[piece] + (v1[piece] - v0[piece]) * t

        k0 = np.where(knots[:-1] == s[piece], self.k0[piece],
                      on_piece(self.k0, self.k1, knots[:-1]))
        k1 = np.where(knots[1:] == s[piece + 1], self.k1[piece],
                      on_piece(self.k0, self.k1, knots[1:]))
        h0 = np.where(knots[:-1] == s[piece], self.h0[piece],
                      on_piece(self.h0, self.h1, knots[:-1]))
        h1 = np.where(knots[1:] == s[piece + 1], self.h1[piece],
                      on_piece(self.h0, self.h1, knots[1:]))
        return Alignment.from_knots(knots, k0, k1, h0, h1)

    # ---------------------------------------------------------------- pointwise values
    def _piece(self, x):
        x = np.asarray(x, dtype=float)
        k = np.clip(np.searchsorted(self.s, x, side="right") - 1, 0, len(self.k0) - 1)
        h = self.s[k + 1] - self.s[k]
        t = np.clip((x - self.s[k]) / h, 0.0, 1.0)
        return k, t

    def curvature(self, x):
        """Curvature at chainage ``x``, 1/m (+ left)."""
        k, t = self._piece(x)
        return self.k0[k] + (self.k1[k] - self.k0[k]) * t

    def cant(self, x):
        """Cant at chainage ``x``, m."""
        k, t = self._piece(x)
        return self.h0[k] + (self.h1[k] - self.h0[k]) * t

    def step_table(self, step: float) -> list[tuple[float, float]]:
        """[start m, radius m] steps of at most ``step`` metres whose curvature is the
        alignment's mean over each step (0 below 1e-6 1/m), for the kernel's curve
        resistance."""
        out: list[tuple[float, float]] = []
        for k in range(len(self.k0)):
            a, b = self.s[k], self.s[k + 1]
            if self.k0[k] == self.k1[k]:
                edges = np.array([a])
            else:
                edges = np.linspace(a, b, max(1, math.ceil((b - a) / step)) + 1)[:-1]
            ends = np.append(edges[1:], b)
            for lo, hi in zip(edges, ends):
                kap = float(self.curvature(0.5 * (lo + hi)))  # mean of a linear piece
                r = 0.0 if abs(kap) < 1e-6 else 1.0 / kap
                if out and out[-1][1] == r:
                    continue
                out.append((float(lo), r))
        kend = float(self.k1[-1])  # beyond the last knot the end value holds
        rend = 0.0 if abs(kend) < 1e-6 else 1.0 / kend
        if out[-1][1] != rend:
            out.append((float(self.s[-1]), rend))
        if not out or out[0][0] > self.s[0]:
            out.insert(0, (float(self.s[0]), 0.0))
        return out

    # ---------------------------------------------------------------- the plane curve
    def _build(self, lo: float, hi: float):
        """Heading and position at the knots of a fine grid over [lo, hi]."""
        lo = min(lo, float(self.s[0])) - 1.0
        hi = max(hi, float(self.s[-1])) + 1.0
        knots = np.concatenate(([lo], self.s, [hi]))
        kmax = float(max(np.max(np.abs(self.k0)), np.max(np.abs(self.k1)), 1e-9))
        piece = min(5.0, 0.05 / kmax)  # at most 0.05 rad of turning per piece
        grid = [knots[0]]
        for a, b in zip(knots[:-1], knots[1:]):
            if b > a:
                n = max(1, math.ceil((b - a) / piece))
                grid.extend(np.linspace(a, b, n + 1)[1:])
        g = np.array(grid)
        theta = np.zeros_like(g)
        # heading: exact integral of the (linear) curvature over each grid piece
        km = self.curvature(0.5 * (g[:-1] + g[1:]))
        theta[1:] = np.cumsum(km * np.diff(g))
        xy = np.zeros((len(g), 2))
        dx, dy = self._chord(g[:-1], theta[:-1], np.diff(g))
        xy[1:, 0] = np.cumsum(dx)
        xy[1:, 1] = np.cumsum(dy)
        self._g, self._theta, self._xy = g, theta, xy

    def _heading_from(self, s0, th0, x):
        """Heading at ``x`` given heading ``th0`` at ``s0`` on the same linear piece."""
        c0 = self.curvature(s0)
        c1 = self.curvature(x)
        return th0 + 0.5 * (c0 + c1) * (x - s0)

    def _chord(self, s0, th0, length):
        """Displacement (dx, dy) along the track from ``s0`` (heading ``th0``) over
        ``length`` (Gauss-Legendre, 8 nodes)."""
        s0 = np.asarray(s0, dtype=float)
        length = np.asarray(length, dtype=float)
        x = s0[..., None] + length[..., None] * _GL_X
        th = self._heading_from(s0[..., None], np.asarray(th0)[..., None], x)
        dx = (np.cos(th) * _GL_W).sum(-1) * length
        dy = (np.sin(th) * _GL_W).sum(-1) * length
        return dx, dy

    def pose(self, x):
        """Plane position (m) and heading (rad) of the centre line at chainage ``x``.

        Returns ``(px, py, theta)`` arrays of ``x``'s shape; chainage 0 is at the origin
        heading along +x only if the alignment starts there; the frame is fixed by the
        start of the grid, which does not matter for angles between bodies.
        """
        x = np.asarray(x, dtype=float)
        if not hasattr(self, "_g") or x.min() < self._g[0] or x.max() > self._g[-1]:
            lo = float(x.min()) if x.size else 0.0
            hi = float(x.max()) if x.size else 0.0
            self._build(lo - 50.0, hi + 50.0)
        g = self._g
        # the grid node at or before x; its piece lies within one linear piece of the
        # alignment (the knots are grid nodes)
        j = np.clip(np.searchsorted(g, x, side="right") - 1, 0, len(g) - 2)
        s0 = g[j]
        th0 = self._theta[j]
        dx, dy = self._chord(s0, th0, x - s0)
        return self._xy[j, 0] + dx, self._xy[j, 1] + dy, self._heading_from(s0, th0, x)


def alignment_of(track) -> Alignment:
    """The :class:`Alignment` of a scenario's ``[track]``: from ``profile`` (points,
    linear between them) if given, else from ``curve`` (steps of radius, + left) with
    its ``transitions`` as linear ramps and ``cant`` linear between its points."""
    if track.profile:
        p = np.asarray(track.profile, dtype=float)
        if len(p) == 1:
            p = np.vstack([p, p + [1.0, 0.0, 0.0]])
        return Alignment.from_knots(p[:, 0], p[:-1, 1], p[1:, 1], p[:-1, 2], p[1:, 2])
    cp = np.asarray(track.curve, dtype=float).reshape(-1, 2)
    kap = np.divide(1.0, cp[:, 1], out=np.zeros(len(cp)), where=cp[:, 1] != 0.0)
    ramps = {float(p): float(L) for p, L in track.transitions}
    # curvature knots: each break either a step or the start of a ramp
    ks, kv = [], []  # (position, curvature) points; a step is two points at one place
    for i, (pos, _) in enumerate(cp):
        before = kap[i - 1] if i else kap[0]
        if i and pos in ramps:
            ks += [pos, pos + ramps[pos]]
            kv += [before, kap[i]]
        else:
            ks += [pos, pos]
            kv += [before, kap[i]]
    hp = np.asarray(track.cant, dtype=float).reshape(-1, 2)
    knots = np.unique(np.concatenate([ks, hp[:, 0]]))
    if len(knots) == 1:
        knots = np.array([knots[0], knots[0] + 1.0])
    ks_a, kv_a = np.array(ks), np.array(kv)

    def kappa_at(x, side):
        # value just after (side right) or just before (left) x of the curvature points
        if side == "right":
            idx = np.searchsorted(ks_a, x, side="right") - 1
            if idx < 0:
                return kv_a[0]
            if idx + 1 < len(ks_a) and ks_a[idx + 1] > ks_a[idx]:
                lo, hi = ks_a[idx], ks_a[idx + 1]
                return kv_a[idx] + (kv_a[idx + 1] - kv_a[idx]) * (x - lo) / (hi - lo)
            return kv_a[idx]
        idx = np.searchsorted(ks_a, x, side="left")
        if idx >= len(ks_a):
            return kv_a[-1]
        if idx == 0:
            return kv_a[0]
        if ks_a[idx] > ks_a[idx - 1]:
            lo, hi = ks_a[idx - 1], ks_a[idx]
            return kv_a[idx - 1] + (kv_a[idx] - kv_a[idx - 1]) * (x - lo) / (hi - lo)
        return kv_a[idx - 1]

    k0 = np.array([kappa_at(a, "right") for a in knots[:-1]])
    k1 = np.array([kappa_at(b, "left") for b in knots[1:]])
    h = np.interp(knots, hp[:, 0], hp[:, 1])
    return Alignment.from_knots(knots, k0, k1, h[:-1], h[1:])


# ------------------------------------------------------------------------ the train
