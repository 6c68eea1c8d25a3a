"""Results accessors of a simulation: node data, stresses, couples and fracture results.

:class:`SimulationResults` is mixed into :class:`~taichi_fdem.simulation.Simulation`; every
method reads the model and the state and returns NumPy arrays in SI units (reported masses and
forces are multiplied by the scene's thickness).
"""
from __future__ import annotations

import numpy as np

from .energies import compute_energies
from .engine.groups import BROKEN
from .engine.joints import MODE_NAMES
from .model import counter


class SimulationResults:
    """Read-only views of a simulation's state as NumPy arrays."""

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

    def node_displacements(self, body=None) -> np.ndarray:
        """x − X [m], shape (n, 2)."""
        return (self.state.node_x.to_numpy().astype(np.float64) - self.model.node_rest)[self._body(body)]

    def set_node_velocities(self, v, body=None) -> None:
        """Overwrite node velocities [m/s] of a body (or all nodes)."""
        allv = self.state.node_v.to_numpy()
        allv[self._body(body)] = np.asarray(v, dtype=allv.dtype)
        self.state.node_v.from_numpy(allv)

    def stresses(self, body=None) -> np.ndarray:
        """Elastic Cauchy stress of each triangle [Pa], shape (m, 2, 2) (§3.2, without the viscous part)."""
        x = self.state.node_x.to_numpy().astype(np.float64)
        t = self.model.tri_nodes_np
        Fx = np.stack([x[t[:, 1]] - x[t[:, 0]], x[t[:, 2]] - x[t[:, 0]]], axis=2)
        F = Fx @ self.model.tri_rest_inv.to_numpy().astype(np.float64)
        J = np.linalg.det(F)
        mu = self.model.mat_mu.to_numpy()[self.model.tri_mat_np][:, None, None]
        lam = self.model.mat_lam.to_numpy()[self.model.tri_mat_np][:, None, None]
        I = np.eye(2)
        T = (mu / J[:, None, None]) * (F @ F.transpose(0, 2, 1) - I) + lam * (J - 1.0 / J)[:, None, None] * I
        if body is None:
            return T
        return T[self._body_obj(body).triangles]

    def energies(self) -> dict:
        """Energy account [J] (per the scene thickness); see :mod:`taichi_fdem.energies`.

        kinetic, strain, contact (penalty potential p∫(φ_c + φ_t)dA plus friction springs),
        gravity (−Σ m g·x), damping / friction / contact_damping (work dissipated so far),
        boundary_work (work done on the system by prescribed velocities), joints (work done on
        intact joints: stored elastically, plus any damage so far) and fracture (work done on
        joints that have broken: dissipated in cracking), and
        total = kinetic + strain + contact + gravity + joints + dissipated − boundary_work, which
        is conserved up to the time-discretisation error.
        """
        return compute_energies(self)

    # ------------------------------------------------------------------------------------------
    # fracture results
    # ------------------------------------------------------------------------------------------
    @property
    def broken_joint_count(self) -> int:
        """Number of joints broken so far."""
        return counter(self.state.step_int, BROKEN) if self.fracture else 0

    def broken_joints(self) -> dict:
        """The joints broken so far (FDEM_SPEC §7.8).

        Returns {"index": (k,) joint indices, "position": (k, 2) mean of the joint's 4 nodes at
        breakage [m], "time": (k,) [s], "mode": (k,) "I", "II", "I+II" or "mixed"}, in time order.
        """
        if not self.fracture:
            return {"index": np.zeros(0, int), "position": np.zeros((0, 2)), "time": np.zeros(0),
                    "mode": np.zeros(0, dtype=object)}
        state = self.state.joint_state.to_numpy()
        idx = np.nonzero(state)[0]
        brk = self.state.joint_break.to_numpy().astype(np.float64)[idx]
        order = np.argsort(brk[:, 0], kind="stable")
        idx, brk = idx[order], brk[order]
        modes = state[idx]                 # a broken joint's state is its failure mode
        return {"index": idx, "position": brk[:, 1:3], "time": brk[:, 0],
                "mode": np.array([MODE_NAMES.get(int(m), "?") for m in modes], dtype=object)}

    def joint_damage(self) -> np.ndarray:
        """Damage of each joint in [0, 1]: the largest stored D of its points, 1 when broken."""
        if not self.fracture:
            return np.zeros(0)
        d = self.state.joint_dmax.to_numpy().astype(np.float64).max(axis=1)
        d[self.state.joint_state.to_numpy() != 0] = 1.0
        return d[: self.joint_count]

    def tri_damage(self) -> np.ndarray:
        """Damage per triangle (m,): the largest damage of its joints (0 for bodies without joints)."""
        out = np.zeros(self.tri_count)
        if self.fracture:
            d = self.joint_damage()
            jt = self.model.joint_tris_np
            np.maximum.at(out, jt[:, 0], d)
            np.maximum.at(out, jt[:, 1], d)
        return out

    def fragment_count(self, body=None) -> int:
        """Number of fragments: triangles connected through intact joints (FDEM_SPEC §7.10).

        A body without fracture counts as one fragment.  With ``body``, only that body's.
        """
        labels = np.arange(self.tri_count)
        for b in self.bodies:
            if not b.fracture:
                labels[b.triangles] = b.tri_start
        if self.fracture:
            intact = self.state.joint_state.to_numpy()[: self.joint_count] == 0
            a, c = self.model.joint_tris_np[intact, 0], self.model.joint_tris_np[intact, 1]
            while True:                      # min-label propagation with pointer jumping
                lo = np.minimum(labels[a], labels[c])
                new = labels.copy()
                np.minimum.at(new, a, lo)
                np.minimum.at(new, c, lo)
                new = new[new]
                if np.array_equal(new, labels):
                    break
                labels = new
        if body is not None:
            b = self._body_obj(body)
            labels = labels[b.triangles]
        return int(len(np.unique(labels)))

    def couples(self) -> np.ndarray:
        """Current couple list as (c, 2) triangle indices (first < second in detection order)."""
        n = self.couple_count
        return np.stack([self.state.couple_a.to_numpy()[:n], self.state.couple_b.to_numpy()[:n]], axis=1)

