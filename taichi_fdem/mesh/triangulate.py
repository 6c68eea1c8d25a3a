"""The hand-written constrained Delaunay triangulator behind :func:`~taichi_fdem.mesh.polygon`
(pure Python and NumPy, private).

:class:`_CDT` triangulates a point set by incremental Bowyer-Watson insertion, restores the
constrained (boundary) edges by edge flips and re-establishes the Delaunay property by Lawson
flips that never cross a constrained edge.
"""
from __future__ import annotations

import math
from collections import deque

import numpy as np

__all__: list = []   # private module: nothing public


class _CDT:
    """Constrained Delaunay triangulation of a point set (private).

    Incremental Bowyer-Watson insertion inside a large super-triangle, then constrained
    edges restored by Sloan's edge-flipping and the Delaunay property re-established by
    Lawson flips that never cross a constrained edge.  Triangles are CCW index triples;
    ``E`` maps each directed edge to the triangle that contains it, which gives the
    adjacency.  Predicates run on coordinates normalised to [-1, 1].
    """

    def __init__(self, points: np.ndarray):
        p = np.asarray(points, dtype=np.float64)
        lo, hi = p.min(axis=0), p.max(axis=0)
        c, s = 0.5 * (lo + hi), 0.5 * float((hi - lo).max())
        q = (p - c) / (s if s > 0 else 1.0)
        self.n = n = len(q)
        big = 1.0e3
        sup = [(0.0, 2.0 * big), (-math.sqrt(3.0) * big, -big), (math.sqrt(3.0) * big, -big)]
        self.x = q[:, 0].tolist() + [s_[0] for s_ in sup]
        self.y = q[:, 1].tolist() + [s_[1] for s_ in sup]
        self.T: list = [(n, n + 1, n + 2)]
        self.E: dict = {(n, n + 1): 0, (n + 1, n + 2): 0, (n + 2, n): 0}
        self.free: list = []
        self.last = 0
        self.constrained: set = set()

    # predicates ------------------------------------------------------------
    def orient(self, a, b, c):
        x, y = self.x, self.y
        return (x[b] - x[a]) * (y[c] - y[a]) - (y[b] - y[a]) * (x[c] - x[a])

    def well_oriented(self, a, b, c):
        """CCW and not nearly degenerate (stricter than TriMesh's degeneracy test)."""
        x, y = self.x, self.y
        abx, aby, acx, acy = x[b] - x[a], y[b] - y[a], x[c] - x[a], y[c] - y[a]
        bcx, bcy = x[c] - x[b], y[c] - y[b]
        d = abx * acy - aby * acx
        return d > 1e-10 * max(abx * abx + aby * aby, acx * acx + acy * acy, bcx * bcx + bcy * bcy)

    def in_circle(self, t, p):
        """> 0 when point p is strictly inside the circumcircle of triangle t (CCW)."""
        a, b, c = self.T[t]
        x, y = self.x, self.y
        px, py = x[p], y[p]
        adx, ady, bdx, bdy, cdx, cdy = x[a] - px, y[a] - py, x[b] - px, y[b] - py, x[c] - px, y[c] - py
        ad, bd, cd = adx * adx + ady * ady, bdx * bdx + bdy * bdy, cdx * cdx + cdy * cdy
        t1, t2, t3 = bdx * cdy - cdx * bdy, cdx * ady - adx * cdy, adx * bdy - bdx * ady
        det = ad * t1 + bd * t2 + cd * t3
        perm = ad * abs(t1) + bd * abs(t2) + cd * abs(t3)
        return det > 1e-12 * perm

    # triangle bookkeeping ---------------------------------------------------
    def _add(self, a, b, c):
        if self.free:
            t = self.free.pop()
            self.T[t] = (a, b, c)
        else:
            t = len(self.T)
            self.T.append((a, b, c))
        E = self.E
        E[(a, b)] = t
        E[(b, c)] = t
        E[(c, a)] = t
        return t

    def _remove(self, t):
        a, b, c = self.T[t]
        E = self.E
        for key in ((a, b), (b, c), (c, a)):
            if E.get(key) == t:
                del E[key]
        self.T[t] = None
        self.free.append(t)

    # insertion ---------------------------------------------------------------
    def locate(self, p):
        t = self.last
        if self.T[t] is None:
            t = next(k for k, tri in enumerate(self.T) if tri is not None)
        E, x, y = self.E, self.x, self.y
        px, py = x[p], y[p]

        def outside(u, v):
            # p farther than 1e-12 (normalised units) on the right of u->v?
            ex, ey = x[v] - x[u], y[v] - y[u]
            o = ex * (py - y[u]) - ey * (px - x[u])
            return o < 0.0 and o * o > 1e-24 * (ex * ex + ey * ey)

        for step in range(4 * len(self.T) + 10):
            a, b, c = self.T[t]
            edges = ((a, b), (b, c), (c, a))
            for k in range(3):
                u, v = edges[(k + step) % 3]
                if outside(u, v):
                    t = E[(v, u)]
                    break
            else:
                return t
        for t, tri in enumerate(self.T):  # pragma: no cover - walk failed (should not happen)
            if tri is not None and not any(outside(u, v) for u, v in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0]))):
                return t
        raise RuntimeError("delaunay: point location failed")  # pragma: no cover

    def insert(self, p):
        t0 = self.locate(p)
        x, y = self.x, self.y
        for q in self.T[t0]:
            if abs(x[q] - x[p]) + abs(y[q] - y[p]) <= 1e-13:
                raise ValueError(f"polygon: duplicate node ({p} and {q})")
        E, T = self.E, self.T
        cavity = {t0}
        rejected = set()
        stack = [t0]
        while stack:
            t = stack.pop()
            a, b, c = T[t]
            for u, v in ((a, b), (b, c), (c, a)):
                nb = E.get((v, u))
                if nb is None or nb in cavity or nb in rejected:
                    continue
                if self.in_circle(nb, p):
                    cavity.add(nb)
                    stack.append(nb)
                else:
                    rejected.add(nb)
        for _ in range(len(cavity) + 8):
            # keep the connected part containing t0, then check it is star-shaped from p
            comp, stack = {t0}, [t0]
            while stack:
                t = stack.pop()
                a, b, c = T[t]
                for u, v in ((a, b), (b, c), (c, a)):
                    nb = E.get((v, u))
                    if nb is not None and nb in cavity and nb not in comp:
                        comp.add(nb)
                        stack.append(nb)
            cavity = comp
            boundary, offenders = [], []
            for t in cavity:
                a, b, c = T[t]
                for u, v in ((a, b), (b, c), (c, a)):
                    if E.get((v, u)) in cavity:
                        continue
                    boundary.append((u, v))
                    if not self.well_oriented(u, v, p):
                        offenders.append((t, u, v))
            if not offenders:
                break
            for t, u, v in offenders:
                if t != t0:
                    cavity.discard(t)
                else:  # p lies on an edge of t0: take the triangle on the other side too
                    nb = E.get((v, u))
                    if nb is None:
                        raise RuntimeError("delaunay: point on the super-triangle boundary")  # pragma: no cover
                    cavity.add(nb)
        else:  # pragma: no cover
            raise RuntimeError("delaunay: could not form a star-shaped cavity")
        for t in cavity:
            self._remove(t)
        for u, v in boundary:
            self.last = self._add(u, v, p)

    def insert_all(self):
        """Insert every input point in a biased randomised order (BRIO): rounds of
        doubling size drawn from a fixed-seed permutation, each round in row-snake order,
        so that cavities stay small and point location walks stay short."""
        n = self.n
        if n == 0:
            return
        q = np.stack([np.array(self.x[:n]), np.array(self.y[:n])], axis=1)
        rank = np.empty(n, dtype=np.int64)
        rank[np.random.default_rng(20240607).permutation(n)] = np.arange(n)
        rnd = np.floor(np.log2(rank + 1.0)).astype(np.int64)
        lo, span = q.min(axis=0), np.maximum(np.ptp(q, axis=0), 1e-300)
        rows = max(1, int(math.sqrt(n / 4.0)))
        r = np.minimum(((q[:, 1] - lo[1]) / span[1] * rows).astype(np.int64), rows - 1)
        key_x = np.where(r % 2 == 0, q[:, 0], -q[:, 0])
        for p in np.lexsort((key_x, r, rnd)).tolist():
            self.insert(p)

    # constrained edges --------------------------------------------------------
    def _third(self, t, u, v):
        a, b, c = self.T[t]
        return c if (a, b) == (u, v) else a if (b, c) == (u, v) else b

    def _flip(self, p, q):
        """Flip edge p-q shared by (p, q, x) and (q, p, y); returns the new edge (x, y)."""
        E, T = self.E, self.T
        t1, t2 = E[(p, q)], E[(q, p)]
        x, y = self._third(t1, p, q), self._third(t2, q, p)
        del E[(p, q)], E[(q, p)]
        T[t1], T[t2] = (x, p, y), (y, q, x)
        E[(x, p)] = E[(p, y)] = E[(y, x)] = t1
        E[(y, q)] = E[(q, x)] = E[(x, y)] = t2
        return x, y

    def _convex(self, p, q):
        E = self.E
        x, y = self._third(E[(p, q)], p, q), self._third(E[(q, p)], q, p)
        return self.well_oriented(x, p, y) and self.well_oriented(y, q, x), x, y

    def _crosses(self, u, v, a, b):
        if a in (u, v) or b in (u, v):
            return False
        o = self.orient
        return o(u, v, a) * o(u, v, b) < 0.0 and o(a, b, u) * o(a, b, v) < 0.0

    def _crossing_edges(self, u, v):
        """Edges (l, r) crossed by segment u-v, l left of u->v, walking from u."""
        o = self.orient
        start = None
        for t, tri in enumerate(self.T):
            if tri is None or u not in tri:
                continue
            k = tri.index(u)
            a, b = tri[(k + 1) % 3], tri[(k + 2) % 3]
            oa, ob = o(u, a, v), o(u, b, v)
            if oa > 0.0 and ob < 0.0:
                start = (b, a)
                break
            if (oa == 0.0 and o(u, v, a) == 0.0 and (self.x[a] - self.x[u]) * (self.x[v] - self.x[u])
                    + (self.y[a] - self.y[u]) * (self.y[v] - self.y[u]) > 0.0):
                raise ValueError(f"polygon: node {a} lies on boundary segment {u}-{v}")
        if start is None:
            raise RuntimeError(f"delaunay: cannot start walking segment {u}-{v}")  # pragma: no cover
        out = [start]
        l, r = start
        for _ in range(len(self.T) + 1):
            c = self._third(self.E[(l, r)], l, r)
            if c == v:
                return out
            side = o(u, v, c)
            if side > 0.0:
                l = c
            elif side < 0.0:
                r = c
            else:
                raise ValueError(f"polygon: node {c} lies on boundary segment {u}-{v}")
            out.append((l, r))
        raise RuntimeError(f"delaunay: walk along segment {u}-{v} did not terminate")  # pragma: no cover

    def recover(self, segments):
        """Make every (u, v) in ``segments`` an edge; then restore Delaunay elsewhere."""
        E = self.E
        for u, v in segments:
            self.constrained.add((min(u, v), max(u, v)))
        for u, v in segments:
            if (u, v) in E or (v, u) in E:
                continue
            queue = deque(self._crossing_edges(u, v))
            new_edges = []
            limit = 50 * len(queue) * len(queue) + 100
            while queue:
                limit -= 1
                if limit < 0:
                    raise RuntimeError(f"delaunay: could not recover segment {u}-{v}")  # pragma: no cover
                p, q = queue.popleft()
                ok, x, y = self._convex(p, q)
                if not ok:
                    queue.append((p, q))
                    continue
                self._flip(p, q)
                if self._crosses(u, v, x, y):
                    queue.append((x, y))
                else:
                    new_edges.append((x, y))
            self._lawson(new_edges)

    def _lawson(self, edges):
        E, stack = self.E, list(edges)
        guard = 100 * (len(self.T) + 10)
        while stack and guard > 0:
            guard -= 1
            p, q = stack.pop()
            if (min(p, q), max(p, q)) in self.constrained or (p, q) not in E or (q, p) not in E:
                continue
            t2 = E[(q, p)]
            y = self._third(t2, q, p)
            if not self.in_circle(E[(p, q)], y):
                continue
            ok, x, y = self._convex(p, q)
            if not ok:
                continue
            self._flip(p, q)
            stack.extend(((p, y), (y, q), (q, x), (x, p)))

    def triangles(self) -> np.ndarray:
        """Triangles not touching the super-triangle, (m, 3) int64."""
        n = self.n
        tri = np.array([t for t in self.T if t is not None], dtype=np.int64).reshape(-1, 3)
        return tri[(tri < n).all(axis=1)]
