"""Results accessors of a simulation: node data, stresses, couples and fracture results.

:class:`SimulationResults` is mixed into :class:`~taichi_fdem.sim.simulation.Simulation`; every
method reads the model and the state and returns NumPy arrays in SI units (reported masses and
forces are multiplied by the scene's thickness).
"""
from __future__ import annotations

import numpy as np

import csv
import os

from ..elasticity import cauchy_svk
from . import heat
from .energies import compute_energies
from .motion import BodyMotion, body_motion_of
from .views import View
from ..engine.groups import BROKEN
from ..engine.loads import LOAD_ABSORB, LOAD_FORCE, LOAD_VELOCITY
from .model import counter


class SimulationResults:
    """Read-only views of a simulation's state as NumPy arrays (crack and fragment results in
    ``sim.cracks``, :class:`~taichi_fdem.sim.cracks.Cracks`; the fluid's in ``sim.fluid``,
    :class:`~taichi_fdem.sim.fluid.FluidResults`)."""

    def _body_obj(self, body):
        """The Body of this simulation that ``body`` (a Body, or its index) names.

        A Body handle of the scene a checkpoint came from is matched by index and name.
        """
        if isinstance(body, (int, np.integer)):
            return self.bodies[int(body)]
        if any(b is body for b in self.bodies):
            return body
        idx = getattr(body, "index", None)
        if isinstance(idx, int) and 0 <= idx < len(self.bodies) and self.bodies[idx].name == getattr(body, "name", None):
            return self.bodies[idx]
        raise ValueError(f"{body!r} is not a body of this simulation")

    def _body(self, body):
        if body is None:
            return slice(None)
        return self._body_obj(body).nodes

    def node_positions(self, body=None) -> np.ndarray:
        """Node positions [m], shape (n, 2), of a body (or of all nodes)."""
        return self.state.node_x.to_numpy().astype(np.float64)[self._body(body)]

    def node_velocities(self, body=None) -> np.ndarray:
        """Node velocities [m/s] at the last half step, shape (n, 2)."""
        return self.state.node_v.to_numpy().astype(np.float64)[self._body(body)]

    def node_masses(self, body=None) -> np.ndarray:
        """Lumped node masses [kg] (ρ A0 t / 3 per triangle), shape (n,)."""
        return self.model.node_mass_np[self._body(body)] * self.thickness

    def body_motion(self, body) -> BodyMotion:
        """Mass, centre of mass, its velocity, angular velocity and the kinetic energy split into
        translation, rotation and vibration of ``body`` (a Body or its index), at the last
        half step: a :class:`~taichi_fdem.sim.motion.BodyMotion` (SI units, thickness included).
        The parts of a body that has broken are summed as one set of nodes."""
        nodes = self._body(self._body_obj(body))
        return body_motion_of(self.node_masses(body), self.node_positions()[nodes], self.node_velocities()[nodes])

    def node_displacements(self, body=None) -> np.ndarray:
        """x − X [m], shape (n, 2)."""
        return (self.state.node_x.to_numpy().astype(np.float64) - self.model.node_rest)[self._body(body)]

    def set_node_velocities(self, v, body=None) -> None:
        """Overwrite node velocities [m/s] of a body (or all nodes)."""
        allv = self.state.node_v.to_numpy()
        allv[self._body(body)] = np.asarray(v, dtype=allv.dtype)
        self.state.node_v.from_numpy(allv)

    def stresses(self, body=None) -> np.ndarray:
        """Elastic Cauchy stress of each triangle [Pa], shape (m, 2, 2) (§3.2, without the viscous part;
        with the initial stress, §12.4; zero for removed triangles).  Bedded triangles follow the
        transversely isotropic law and thermal strains the split F = F_e F_th
        (docs/theory/anisotropy.md)."""
        x = self.state.node_x.to_numpy().astype(np.float64)
        t = self.model.tri_nodes_np
        Fx = np.stack([x[t[:, 1]] - x[t[:, 0]], x[t[:, 2]] - x[t[:, 0]]], axis=2)
        F = Fx @ self.model.tri_rest_inv.to_numpy().astype(np.float64)
        J = np.linalg.det(F)
        T = self._elastic_stresses(F, J)
        S0 = self.model.tri_prestress_np
        if self.model.prestress:            # initial stress: + F S⁰ Fᵀ / J (docs/theory/loads.md §12.4)
            S = np.stack([np.stack([S0[:, 0], S0[:, 2]], 1), np.stack([S0[:, 2], S0[:, 1]], 1)], 1)
            T = T + F @ S @ F.transpose(0, 2, 1) / J[:, None, None]
        T[self.state.tri_intact.to_numpy() < 0] = 0.0      # removed by an excavation
        if body is None:
            return T
        return T[self._body_obj(body).triangles]

    def _elastic_stresses(self, F, J) -> np.ndarray:
        """The elastic Cauchy stress [Pa] of the triangles at deformation gradients F (E, 2, 2),
        J = det F: the host twin of engine.elastic.elastic_stress."""
        md = self.model
        Fe, Je = F, J
        if md.heat:                         # F = F_e F_th, F_th = I + ε*
            th = self.state.tri_thermal.to_numpy().astype(np.float64)
            Fth = np.stack([np.stack([1.0 + th[:, 0], th[:, 2]], 1), np.stack([th[:, 2], 1.0 + th[:, 1]], 1)], 1)
            Fe = F @ np.linalg.inv(Fth)
            Je = np.linalg.det(Fe)
        lame = md.mat_lame.to_numpy()[md.tri_mat_np]
        mu, lam = lame[:, 0, None, None], lame[:, 1, None, None]
        I = np.eye(2)
        T = (mu / Je[:, None, None]) * (Fe @ Fe.transpose(0, 2, 1) - I) + lam * (Je - 1.0 / Je)[:, None, None] * I
        if md.bedding:
            cs = md.tri_bedding.to_numpy().astype(np.float64)
            on = np.any(cs != 0.0, axis=1)
            C = md.mat_aniso.to_numpy().astype(np.float64)[md.tri_mat_np[on]]
            T[on] = cauchy_svk(Fe[on], cs[on, 0], cs[on, 1], C)
        return T

    # ------------------------------------------------------------------------------------------
    # loads and reactions (docs/theory/loads.md §12)
    # ------------------------------------------------------------------------------------------
    def _node_selection(self, body, where, what: str) -> np.ndarray:
        sel = np.ones(self.model.node_count, bool)
        if body is not None:
            mask = np.zeros_like(sel)
            mask[self._body_obj(body).nodes] = True
            sel &= mask
        if where is not None:
            if not callable(where):
                raise TypeError(f"{what}: where must be a callable where(x, y) -> bool array (initial coordinates)")
            X = self.model.node_rest
            w = np.asarray(where(X[:, 0].copy(), X[:, 1].copy()), dtype=bool)
            if w.shape != sel.shape:
                raise ValueError(f"{what}: where(x, y) must return a boolean array of shape ({len(sel)},)")
            sel &= w
        return sel

    def reaction(self, body=None, where=None) -> np.ndarray:
        """Total force (2,) [N, i.e. N/m × the thickness] that the velocity constraints exerted
        on the selected nodes at the last step (docs/theory/loads.md §12.3).

        Per constrained node component R = m (v_b − v_free)/Δt, v_free the velocity the node
        would have had unconstrained; free components contribute nothing.  Selection: the nodes
        of ``body`` and/or those whose initial coordinates satisfy ``where(x, y)`` (all
        constrained nodes when both are None).  For a platen driven by a prescribed velocity,
        ``reaction(platen)`` is the force it transmits to what it pushes (at equilibrium, minus the
        load on that side), plus what holds the platen itself against gravity.  Zeros before the
        first step.  A component whose sum lies within the round-off of summing its terms
        (``|Σ R_i| <= 2 n ε Σ |R_i|``, ε of the state's precision) is exactly 0: a fixed body
        that nothing touches reacts with no force.
        """
        sel = self._node_selection(body, where, "reaction")
        md = self.model
        if not md.has_bc:
            raise ValueError("reaction: the scene has no prescribed velocities (fix_nodes, fixed or "
                             "prescribed_velocity bodies)")
        free = md.node_free.to_numpy()
        sel &= np.any(free == 0.0, axis=1) & ~getattr(self, "_orphans", np.zeros_like(sel))
        if not sel.any():
            raise ValueError("reaction: the selection holds no node with a prescribed velocity")
        r = self.state.node_react.to_numpy()
        eps = float(np.finfo(r.dtype).eps)
        r = r.astype(np.float64)[sel]
        total = r.sum(axis=0)
        # a component within the round-off of its own sum is no force: report exactly 0
        total[np.abs(total) <= 2.0 * len(r) * eps * np.abs(r).sum(axis=0)] = 0.0
        return total * self.thickness

    def active_triangles(self) -> np.ndarray:
        """(m,) bool: the triangles not removed by :meth:`remove`."""
        return self.state.tri_intact.to_numpy() >= 0

    def energies(self) -> dict:
        """Energy account [J] (per the scene thickness); see :mod:`taichi_fdem.sim.energies`.

        kinetic, strain, contact (penalty potential p∫(φ_c + φ_t)dA plus friction springs),
        gravity (−Σ m g·x), damping / friction / contact_damping (work dissipated so far),
        boundary_work (work done on the system by prescribed velocities), joints (work done on
        intact joints: stored elastically, plus any damage so far) and fracture (work done on
        joints that have broken: dissipated in cracking), and
        total = kinetic + strain + contact + gravity + joints + dissipated − boundary_work, which
        is conserved up to the time-discretisation error.
        """
        return compute_energies(self)

    def _history_row(self) -> dict:
        """One row of the history recorder (see :class:`History`)."""
        row = {"time": self.time, "step": self.step_count}
        md = self.model
        if md.has_bc:
            r = self.state.node_react.to_numpy().astype(np.float64) * self.thickness
            for label, mask in zip(md.bc_group_labels, md.bc_group_masks):
                row[f"reaction_{label}_x"], row[f"reaction_{label}_y"] = r[mask].sum(axis=0)
        for name, a in self.loads.factors().items():
            row[f"factor_{name}"] = a
        u = self.node_displacements()
        for b in self.bodies:
            row[f"ux_{b.name}"], row[f"uy_{b.name}"] = u[b.nodes].mean(axis=0)
        if md.fracture:
            row["broken_joints"] = self.cracks.broken_count
            row["crack_length"] = self.cracks.length()
        if md.fluid:
            self.fluid._fluid_history(row)
        if getattr(md, "heat", False):
            heat.heat_history(self, row)
        for k, v in self.energies().items():
            row[f"E_{k}"] = float(v)
        return row

    def temperatures(self) -> np.ndarray:
        """Temperature of each node, shape (N,) [the scale of the scene's temperatures]
        (docs/guide/heat.md); ValueError for a scene without heat."""
        return heat.temperatures(self)

    def heat_flow(self) -> np.ndarray:
        """Heat flux density q = −k ∇T of each triangle, shape (E, 2) [W/m²] (docs/theory/heat.md §16.2)."""
        return heat.heat_flow(self)

    def couples(self) -> np.ndarray:
        """Current couple list as (c, 2) triangle indices.  The first ``model.nb_count`` are the
        neighbour pairs of fracturing bodies (two bonded triangles sharing a node of the unsplit
        mesh; contact skips them while ``state.tri_nb_on`` is 0), then the couples found by the
        last detection (first < second in detection order)."""
        n = self._couple_count()
        return np.stack([self.state.couple_a.to_numpy()[:n], self.state.couple_b.to_numpy()[:n]], axis=1)



class Loads(View):
    """``sim.loads``: the forces and amplitudes of the scene's applied loads now."""

    def forces(self) -> np.ndarray:
        """Nodal forces of the applied pressure, tractions and point forces at the last step [N],
        shape (n, 2) (× the thickness; absorbing dashpots not included)."""
        out = np.zeros((self._sim.model.node_count, 2))
        if not self._sim.model.loads:
            return out
        ln = self._sim.model.load_nodes.to_numpy()
        f = self._sim.state.load_force.to_numpy().astype(np.float64)
        use = (ln[:, 0] != LOAD_ABSORB) & (ln[:, 0] != LOAD_VELOCITY)
        np.add.at(out, ln[use, 1], f[use, 0:2])
        two = use & (ln[:, 0] != LOAD_FORCE)
        np.add.at(out, ln[two, 2], f[two, 2:4])
        return out * self._sim.thickness

    def factors(self) -> dict:
        """{curve name: amplitude A at the current time} of the scene's curves (named by
        ``Curve(name=...)``, else ``curve0``, ``curve1``, ... in order of first use)."""
        return {_curve_name(c, k): float(np.interp(self._sim.time, c.times, c.values))
                for k, c in enumerate(self._sim.model.curves)}


def _curve_name(curve, k: int) -> str:
    return getattr(curve, "name", None) or f"curve{k}"


class HistoryFile:
    """A CSV history of a run, appended row by row and flushed (the file of the
    :class:`~taichi_fdem.sim.recorders.History` recorder).

    Columns: time [s], step, the reaction (x, y) [N] of each prescribed body (by name) and of
    each ``fix_nodes`` group (fix0, fix1, ...), the amplitude of each curve, the mean
    displacement (x, y) [m] of each body, with fracture the number of broken joints
    (``broken_joints``) and their total initial length (``crack_length`` [m]), with a fluid
    the pressure at the first source (``fluid_injection_pressure`` [Pa]), the net volume the
    sources put in (``fluid_injected_volume``), the volume stored in the network
    (``fluid_stored_volume``, both [m² per unit thickness]) and each source's rate
    (``fluid_rate_0``, ... [m²/s]), and the energy account [J] (``E_load_work`` included, and
    ``E_fluid_work`` with a fluid).
    A file that exists is appended to (its header is kept).
    """

    def __init__(self, sim, path):
        self.sim, self.path = sim, os.fspath(path)
        d = os.path.dirname(os.path.abspath(self.path))
        os.makedirs(d, exist_ok=True)
        self.fields = list(sim._history_row().keys())
        new = not os.path.exists(self.path) or os.path.getsize(self.path) == 0
        self.fh = open(self.path, "a", newline="")
        self.writer = csv.DictWriter(self.fh, fieldnames=self.fields, extrasaction="ignore")
        if new:
            self.writer.writeheader()

    def write(self) -> None:
        self.writer.writerow(self.sim._history_row())
        self.fh.flush()

    def close(self) -> None:
        self.fh.close()



#: the name of :class:`HistoryFile` in version 0.1.0
History = HistoryFile
