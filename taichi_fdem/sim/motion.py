"""Rigid-body summary of a deformable body's motion (docs/guide/outputs.md, "Body motion").

For nodes of lumped masses m_i at x_i with velocities v_i (a body of the mesh, thickness t
included in the masses):

- mass M = Σ m_i, centre of mass c = Σ m_i x_i / M, velocity of the centre v_c = Σ m_i v_i / M;
- angular momentum about the centre L = Σ m_i (x_i − c) × (v_i − v_c) (the z component),
  polar moment of inertia I = Σ m_i ‖x_i − c‖², angular velocity ω = L / I;
- kinetic energy K = ½ Σ m_i ‖v_i‖² = K_translation + K_rotation + K_vibration with
  K_translation = ½ M ‖v_c‖², K_rotation = ½ I ω² = ½ L² / I, and K_vibration the rest: the
  energy of the motion relative to the best-fitting rigid motion, ≥ 0 (Koenig's theorem and
  the least-squares rigid fit of the velocity field).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class BodyMotion:
    """Motion of one body: see :mod:`taichi_fdem.sim.motion` for the definitions.

    Units: ``mass`` [kg], ``center`` [m] (2,), ``velocity`` [m/s] (2,) of the centre of mass,
    ``angular_velocity`` [rad/s] (counter-clockwise positive), ``momentum`` [kg m/s] (2,),
    ``angular_momentum`` [kg m²/s] about the centre, ``inertia`` [kg m²] about the centre,
    energies [J].
    """
    mass: float
    center: np.ndarray
    velocity: np.ndarray
    angular_velocity: float
    momentum: np.ndarray
    angular_momentum: float
    inertia: float
    kinetic_energy: float
    translational_energy: float
    rotational_energy: float
    vibrational_energy: float


def body_motion_of(m: np.ndarray, x: np.ndarray, v: np.ndarray) -> BodyMotion:
    """:class:`BodyMotion` of nodes with masses ``m`` (n,), positions ``x`` and velocities
    ``v`` (n, 2).  Raises ValueError when the total mass is not positive."""
    m = np.asarray(m, np.float64)
    x = np.asarray(x, np.float64)
    v = np.asarray(v, np.float64)
    mass = float(m.sum())
    if not mass > 0.0:
        raise ValueError(f"body_motion: the body's mass is {mass!r} kg; it must be positive")
    center = (m[:, None] * x).sum(axis=0) / mass
    momentum = (m[:, None] * v).sum(axis=0)
    vc = momentum / mass
    r, u = x - center, v - vc
    inertia = float((m * (r * r).sum(axis=1)).sum())
    ang_mom = float((m * (r[:, 0] * u[:, 1] - r[:, 1] * u[:, 0])).sum())
    omega = ang_mom / inertia if inertia > 0.0 else 0.0
    kinetic = 0.5 * float((m * (v * v).sum(axis=1)).sum())
    trans = 0.5 * mass * float(vc @ vc)
    rot = 0.5 * ang_mom * omega
    vib = 0.5 * float((m * (u * u).sum(axis=1)).sum()) - rot
    return BodyMotion(mass=mass, center=center, velocity=vc, angular_velocity=omega, momentum=momentum,
                      angular_momentum=ang_mom, inertia=inertia, kinetic_energy=kinetic,
                      translational_energy=trans, rotational_energy=rot, vibrational_energy=max(vib, 0.0))
