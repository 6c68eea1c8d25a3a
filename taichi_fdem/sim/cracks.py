"""Crack and fragment results of a simulation (docs/theory/joints.md §7.8–7.10, §13.4): the
view ``sim.cracks`` (:class:`Cracks`).

* **Crack events** (:meth:`Cracks.events`): every broken joint is one event with its time,
  position, failure mode, released energy (the work done on the joint up to breakage, × the
  scene thickness), initial length and joint set; :meth:`~Cracks.write_events` writes them as
  CSV, :class:`CrackEventLog` streams them during a run (the
  :class:`~taichi_fdem.sim.recorders.CrackEvents` recorder) and :func:`read_crack_events`
  reads such a file back.
* **Fragments** (:meth:`Cracks.fragments`): triangles are in one fragment when they share a
  node or are joined by an intact joint; per fragment its initial area, mass and current
  centroid; :meth:`~Cracks.fragment_sizes` and :meth:`~Cracks.fragment_passing` give the size
  distribution.

Everything is vectorised NumPy (no Python loop over triangles, nodes or joints).
"""
from __future__ import annotations

import csv
import os

import numpy as np

from ..engine.joints import MODE_NAMES
from .ae import _components
from .views import View

__all__ = ["Cracks", "CrackEventLog", "read_crack_events", "CSV_COLUMNS"]

#: columns of a crack-event CSV file, with the units in their names
CSV_COLUMNS = ("joint", "time_s", "x_m", "y_m", "mode", "energy_J", "length_m", "set", "pressure_Pa")
# events() key of each CSV column
_CSV_KEYS = ("index", "time", "x", "y", "mode", "energy", "length", "set", "pressure")
_MODE_TABLE = np.array(["?"] + [MODE_NAMES[k] for k in sorted(MODE_NAMES)], dtype=object)
_MODE_IDS = {name: k for k, name in MODE_NAMES.items()}


def _empty_events() -> dict:
    f = np.zeros(0)
    return {"index": np.zeros(0, np.int64), "time": f, "x": f.copy(), "y": f.copy(),
            "mode": np.zeros(0, dtype=object), "mode_id": np.zeros(0, np.int32), "energy": f.copy(),
            "length": f.copy(), "set": np.zeros(0, dtype=object), "set_id": np.zeros(0, np.int32), "pressure": f.copy()}


class Cracks(View):
    """``sim.cracks``: broken joints, crack events, crack length, damage and fragments of a
    simulation (NumPy arrays, SI units)."""

    # ---- constant joint data (the model never changes during a run) --------------------------
    def _joint_consts(self) -> dict:
        """Joint nodes (k, 4), initial lengths L0 (k,) [m], set ids (k,) and set names; cached."""
        c = self._cache.get("joint_consts")
        if c is not None:
            return c
        md = self._sim.model
        k = int(md.joint_count) if md.fracture else 0
        jn = md.joint_nodes.to_numpy()[:k].astype(np.int64)
        X = np.asarray(md.node_rest, dtype=np.float64)
        # L0 = |½(X1 + X2 − X0 − X3)|: the length the joint kernel evaluates, at rest
        length = np.linalg.norm(0.5 * (X[jn[:, 1]] + X[jn[:, 2]] - X[jn[:, 0]] - X[jn[:, 3]]), axis=1)
        sets = getattr(md, "joint_set_np", None)
        names = getattr(md, "joint_set_names", None)
        if sets is None or names is None or len(names) == 0:
            sets, names = np.zeros(k, np.int32), ["default"]
        sets = np.asarray(sets, dtype=np.int32)[:k]
        if len(sets) != k:
            raise ValueError(f"crack results: model.joint_set_np has {len(sets)} entries for {k} joints")
        c = {"nodes": jn, "length": length, "set_id": sets, "set_names": np.array(list(names), dtype=object)}
        self._cache["joint_consts"] = c
        return c

    def _broken_mask(self) -> np.ndarray:
        k = int(self._sim.model.joint_count) if self._sim.model.fracture else 0
        return self._sim.state.joint_state.to_numpy()[:k] != 0

    # ---- crack events --------------------------------------------------------------------------
    def events(self) -> dict:
        """The broken joints as crack events, in time order (docs/theory/joints.md §7.8, §13.4).

        Returns a dict of NumPy arrays, one entry per event:

        * ``index``: the joint's index; ``time`` [s]: when it broke (start of the step);
        * ``x``, ``y`` [m]: the mean of its 4 nodes at breakage;
        * ``mode``: "I", "II", "I+II" or "mixed" (§7.8), ``mode_id`` the same as 1..4;
        * ``energy`` [J]: energy released = the work done on the joint up to breakage (pre-peak
          share included, §7.9) × the scene thickness; the events' sum is
          ``energies()["fracture"]``;
        * ``length`` [m]: the joint's initial length L0 (from the rest positions);
        * ``set``: the name of its joint set ("default" without joint sets), ``set_id`` its index;
        * ``pressure`` [Pa]: the fluid pressure at the joint when it broke, the mean of the
          pressures at its two ends at the start of the step (``scene.set_fluid``; 0 where the
          fluid has not arrived); NaN in a scene without a fluid.

        Ties in time are in joint order.  Empty arrays for a scene without fracture.
        """
        if not self._sim.model.fracture or not self._sim.model.joint_count:
            return _empty_events()
        broken = self._broken_mask()
        idx = np.nonzero(broken)[0]
        return self._events_of(idx)

    def _events_of(self, idx: np.ndarray) -> dict:
        """The events of the broken joints ``idx`` (sorted by time, then index)."""
        if len(idx) == 0:
            return _empty_events()
        st, c = self._sim.state, self._joint_consts()
        brk = st.joint_break.to_numpy()[idx].astype(np.float64)
        order = np.lexsort((idx, brk[:, 0]))
        idx, brk = idx[order], brk[order]
        mode_id = st.joint_state.to_numpy()[idx].astype(np.int32)
        energy = st.joint_work.to_numpy()[idx].astype(np.float64) * self._sim.thickness
        set_id = c["set_id"][idx]
        pressure = np.where(brk[:, 3] >= 0.0, brk[:, 3], np.nan)
        return {"index": idx.astype(np.int64), "time": brk[:, 0], "x": brk[:, 1], "y": brk[:, 2],
                "mode": _MODE_TABLE[np.clip(mode_id, 0, len(_MODE_TABLE) - 1)], "mode_id": mode_id,
                "energy": energy, "length": c["length"][idx], "set": c["set_names"][set_id], "set_id": set_id,
                "pressure": pressure}

    def write_events(self, path) -> str:
        """Write :meth:`events` as a CSV file (overwritten), columns :data:`CSV_COLUMNS`
        (``joint, time_s, x_m, y_m, mode, energy_J, length_m, set, pressure_Pa``); returns the path.

        Floats are written with ``repr`` (exact round trip, :func:`read_crack_events`)."""
        path = os.fspath(path)
        d = os.path.dirname(os.path.abspath(path))
        os.makedirs(d, exist_ok=True)
        tmp = path + ".tmp"
        with open(tmp, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(CSV_COLUMNS)
            _write_rows(w, self.events())
        os.replace(tmp, path)
        return path

    def ae_events(self, window_distance: float | None = None, window_time: float | None = None,
                  energy_to_moment: float | None = None) -> dict:
        """The crack events clustered into acoustic-emission events (:func:`taichi_fdem.sim.ae.ae_events`:
        time, location, energy [J], seismic moment [N·m], moment magnitude M_w (Hanks & Kanamori
        1979 with Kanamori's 1977 energy-moment ratio), crack count and mode).

        Parameters
        ----------
        window_distance : float or None
            Link radius [m] (default: 2 × the mean initial length of the broken joints).
        window_time : float or None
            Link time [s] (default: ``window_distance`` / the largest plane-strain P-wave
            speed of the scene's materials: the time a signal needs to cross the window).
        energy_to_moment : float or None
            Radiated energy / seismic moment (default 5e-5, Kanamori 1977).
        """
        from . import ae
        ev = self.events()
        if window_distance is None:
            window_distance = 2.0 * float(ev["length"].mean()) if len(ev["length"]) else 1.0
        if window_time is None:
            cp = max(m.p_wave_speed("strain") for m in self._sim.model.materials)
            window_time = float(window_distance) / cp
        return ae.ae_events(ev, window_time, window_distance,
                            ae.ENERGY_TO_MOMENT if energy_to_moment is None else energy_to_moment)

    def write_ae_events(self, path, **windows) -> str:
        """Write :meth:`ae_events` (``**windows``: its keyword arguments) as CSV; returns the path.
        Columns: ``event, time_s, end_s, x_m, y_m, energy_J, moment_Nm, magnitude, cracks, mode``."""
        from . import ae
        return ae.write_ae_events(path, self.ae_events(**windows))

    def segments(self) -> np.ndarray:
        """Current midlines of the broken joints [m], (k, 4) rows (x_a, y_a, x_b, y_b) in the
        order of :meth:`events`: from ½(x_j0 + x_j3) to ½(x_j1 + x_j2)."""
        ev = self.events()
        jn = self._joint_consts()["nodes"][ev["index"]] if len(ev["index"]) else np.zeros((0, 4), np.int64)
        x = self._sim.state.node_x.to_numpy().astype(np.float64)
        a = 0.5 * (x[jn[:, 0]] + x[jn[:, 3]])
        b = 0.5 * (x[jn[:, 1]] + x[jn[:, 2]])
        return np.concatenate([a, b], axis=1)

    def length(self) -> float:
        """Total initial length L0 of the joints broken so far [m] (per the 2D section)."""
        if not self._sim.model.fracture or not self._sim.model.joint_count:
            return 0.0
        return float(self._joint_consts()["length"][self._broken_mask()].sum())

    def length_history(self) -> tuple:
        """(times [s], cumulative crack length [m]) at each crack event, in time order:
        the length after the k-th event is the sum of the initial lengths of the first k."""
        ev = self.events()
        return ev["time"].copy(), np.cumsum(ev["length"])

    # ---- broken joints and damage ------------------------------------------------------------
    @property
    def broken_count(self) -> int:
        """Number of joints broken so far."""
        return self._sim.state.counters.broken if self._sim.model.fracture else 0

    def broken(self) -> dict:
        """The joints broken so far (docs/theory/joints.md §7.8); see :meth:`events` for more.

        Returns {"index": (k,) joint indices, "position": (k, 2) mean of the joint's 4 nodes at
        breakage [m], "time": (k,) [s], "mode": (k,) "I", "II", "I+II" or "mixed"}, in time order.
        """
        ev = self.events()
        return {"index": ev["index"], "position": np.stack([ev["x"], ev["y"]], axis=1), "time": ev["time"],
                "mode": ev["mode"]}

    def joint_damage(self) -> np.ndarray:
        """Damage of each joint in [0, 1]: the largest stored D of its points, 1 when broken."""
        if not self._sim.model.fracture:
            return np.zeros(0)
        d = self._sim.state.joint_dmax.to_numpy().astype(np.float64).max(axis=1)
        d[self._sim.state.joint_state.to_numpy() != 0] = 1.0
        return d[: self._sim.model.joint_count]

    def tri_damage(self) -> np.ndarray:
        """Damage per triangle (m,): the largest damage of its joints (0 for bodies without joints)."""
        out = np.zeros(self._sim.model.tri_count)
        if self._sim.model.fracture:
            d = self.joint_damage()
            jt = self._sim.model.joint_tris_np
            np.maximum.at(out, jt[:, 0], d)
            np.maximum.at(out, jt[:, 1], d)
        return out

    def fragment_count(self, body=None) -> int:
        """Number of fragments: groups of triangles connected by shared nodes or intact joints
        (docs/theory/joints.md §7.10; the labelling of :meth:`fragments`).  Triangles removed by
        ``sim.remove`` count for nothing.  With ``body``, only that body's.
        """
        return self._fragment_labels(body)[2]

    # ---- fragments -----------------------------------------------------------------------------
    def _fragment_roots(self) -> np.ndarray:
        """Per triangle the smallest index of a triangle of its fragment (−1 for removed
        triangles).  Connected: sharing a node, or an intact joint (joint_state == 0) between
        two present triangles.  Vectorised hooking and pointer jumping over the triangle pairs
        (each triangle to the first triangle of each of its nodes, and the intact joints):
        parent[t] ≤ t always, so each component ends at its smallest triangle."""
        md = self._sim.model
        m = md.tri_count
        active = self._sim.state.tri_intact.to_numpy()[:m] >= 0
        ta = np.nonzero(active)[0]
        flat = md.tri_nodes_np[ta].ravel()
        first = np.full(md.node_count, m, np.int64)       # first present triangle at each node
        np.minimum.at(first, flat, np.repeat(ta, 3))
        u, v = [np.repeat(ta, 3)], [first[flat]]
        if md.fracture and md.joint_count:
            jt = md.joint_tris_np
            keep = (self._sim.state.joint_state.to_numpy()[: len(jt)] == 0) & active[jt[:, 0]] & active[jt[:, 1]]
            u.append(jt[keep, 0])
            v.append(jt[keep, 1])
        u, v = np.concatenate(u), np.concatenate(v)
        parent = _components(m, u, v)                    # hooking and pointer jumping
        parent[~active] = -1
        return parent

    def _fragment_labels(self, body=None):
        """(triangle indices, fragment id per triangle (−1 removed), fragment count) of all
        triangles or of ``body``'s; ids 0..count−1 in order of each fragment's first triangle."""
        roots = self._fragment_roots()
        tris = np.arange(len(roots)) if body is None else np.arange(len(roots))[self._sim._body_obj(body).triangles]
        roots = roots[tris]
        label = np.full(len(tris), -1, np.int64)
        ok = roots >= 0
        uniq, inv = np.unique(roots[ok], return_inverse=True)
        label[ok] = inv
        return tris, label, len(uniq)

    def fragments(self, body=None) -> dict:
        """The fragments now (docs/theory/joints.md §7.10): triangles joined by a shared node or an intact
        joint form one fragment.  With ``body``, that body's triangles only.

        Returns {``label``: (m,) fragment id of each triangle (of ``body`` if given; −1 for
        triangles removed by ``sim.remove``), ``area``: (count,) initial area of each fragment
        [m²], ``mass``: (count,) [kg] (ρ A0 × thickness), ``centroid``: (count, 2) current
        mass-weighted centroid [m], ``count``}.
        """
        md = self._sim.model
        tris, label, count = self._fragment_labels(body)
        ok = label >= 0
        t, lab = tris[ok], label[ok]
        area0 = np.asarray(md.tri_area0_np, dtype=np.float64)[t]
        rho = np.array([mat.density for mat in md.materials], dtype=np.float64)[md.tri_mat_np[t]]
        tmass = rho * area0 * self._sim.thickness
        x = self._sim.state.node_x.to_numpy().astype(np.float64)
        cen = x[md.tri_nodes_np[t]].mean(axis=1)
        area = np.bincount(lab, weights=area0, minlength=count)
        mass = np.bincount(lab, weights=tmass, minlength=count)
        with np.errstate(invalid="ignore", divide="ignore"):
            centroid = np.stack([np.bincount(lab, weights=tmass * cen[:, 0], minlength=count),
                                 np.bincount(lab, weights=tmass * cen[:, 1], minlength=count)], axis=1) / mass[:, None]
        return {"label": label, "area": area, "mass": mass, "centroid": centroid, "count": int(count)}

    def fragment_sizes(self, body=None) -> dict:
        """Fragment sizes, largest first: {``area`` [m²] (initial), ``mass`` [kg], ``diameter``
        [m] (equivalent diameter √(4A/π)), ``label`` (fragment id in :meth:`fragments`)}."""
        f = self.fragments(body)
        order = np.argsort(-f["area"], kind="stable")
        area = f["area"][order]
        return {"area": area, "mass": f["mass"][order], "diameter": np.sqrt(4.0 * area / np.pi), "label": order}

    def fragment_passing(self, d=None, body=None):
        """Cumulative size distribution by mass (a sieve curve).

        With ``d`` (a diameter [m] or an array of them): the fraction of the fragments' total
        mass in fragments whose equivalent diameter √(4A/π) is ≤ d (same shape as ``d``).
        Without: (diameters ascending [m], fraction of mass ≤ each diameter), ending at 1.
        """
        s = self.fragment_sizes(body)
        dia, mass = s["diameter"][::-1], s["mass"][::-1]
        total = mass.sum()
        frac = np.cumsum(mass) / total if total > 0 else np.zeros_like(mass)
        if d is None:
            return dia, frac
        d = np.asarray(d, dtype=np.float64)
        if not np.all(np.isfinite(d)):
            raise ValueError("fragment_passing: d must hold finite diameters [m]")
        k = np.searchsorted(dia, d, side="right")
        out = np.where(k > 0, frac[np.maximum(k - 1, 0)] if len(frac) else 0.0, 0.0)
        return float(out) if out.ndim == 0 else out


# ------------------------------------------------------------------------------------------------
# CSV
# ------------------------------------------------------------------------------------------------
def _write_rows(writer, ev: dict) -> None:
    cols = [ev[k].tolist() for k in _CSV_KEYS]        # Python ints / floats (repr: exact round trip)
    writer.writerows(zip(*cols))


def read_crack_events(path) -> dict:
    """A crack-event CSV (:meth:`Cracks.write_events` or the file of a
    :class:`~taichi_fdem.sim.recorders.CrackEvents` recorder) as the dict of
    :meth:`Cracks.events` (without ``set_id``)."""
    with open(os.fspath(path), newline="") as fh:
        rows = list(csv.reader(fh))
    if not rows or tuple(rows[0]) != CSV_COLUMNS:
        raise ValueError(f"read_crack_events: {os.fspath(path)!r} is not a crack-event file "
                         f"(header must be {','.join(CSV_COLUMNS)})")
    body = rows[1:]
    cols = list(zip(*body)) if body else [()] * len(CSV_COLUMNS)
    ev = {"index": np.array(cols[0], dtype=np.int64)}
    for k, name in ((1, "time"), (2, "x"), (3, "y"), (5, "energy"), (6, "length"), (8, "pressure")):
        ev[name] = np.array(cols[k], dtype=np.float64)
    ev["mode"] = np.array(cols[4], dtype=object)
    ev["mode_id"] = np.array([_MODE_IDS.get(m, 0) for m in cols[4]], dtype=np.int32)
    ev["set"] = np.array(cols[7], dtype=object)
    return ev


class CrackEventLog:
    """Appends new crack events to a CSV file as a run goes (``Simulation.run(crack_events=...)``).

    :meth:`write` adds the joints broken since the last call (time order) and flushes; it reads
    only the broken-joint counter when nothing new broke.  An existing file is appended to: the
    joints it already lists are not written again (its header must be :data:`CSV_COLUMNS`).
    """

    def __init__(self, sim, path):
        self.sim, self.path = sim, os.fspath(path)
        os.makedirs(os.path.dirname(os.path.abspath(self.path)), exist_ok=True)
        k = int(sim.model.joint_count) if sim.model.fracture else 0
        self.written = np.zeros(k, bool)
        if os.path.exists(self.path) and os.path.getsize(self.path) > 0:
            old = read_crack_events(self.path)["index"]
            old = old[(old >= 0) & (old < k)]
            self.written[old] = True
            new = False
        else:
            new = True
        self.seen = -1                                    # broken-joint count at the last write
        self.fh = open(self.path, "a", newline="")
        self.writer = csv.writer(self.fh)
        if new:
            self.writer.writerow(CSV_COLUMNS)
            self.fh.flush()

    def write(self) -> int:
        """Append the events not yet in the file; returns how many were written."""
        sim = self.sim
        if not len(self.written):
            return 0
        n = sim.state.counters.broken
        if n == self.seen:
            return 0
        self.seen = n
        idx = np.nonzero(sim.cracks._broken_mask() & ~self.written)[0]
        if len(idx):
            _write_rows(self.writer, sim.cracks._events_of(idx))
            self.fh.flush()
            self.written[idx] = True
        return len(idx)

    def close(self) -> None:
        if self.fh.closed:
            return
        try:
            self.write()
        finally:
            self.fh.close()
