"""Certificates of separation (``engine.contact.couple_forces``): a couple found apart with a gap
g is skipped while the displacement bound D_acc (docs/theory/contact.md §4.1) grows by less than g.  Every
certificate must hold (checked against brute-force distances between the triangles), and
skipping must change no bit (checked against runs that never use a certificate: the host drops
them at every launch, and a launch of one step sets them only after they could be used)."""
from __future__ import annotations

import math

import numpy as np
import pytest

import taichi_fdem as fdem
from taichi_fdem.engine.groups import DACC
from taichi_fdem.sim.model import counter


def _pile(strategy: str, seed: int = 0, speed: float = 0.3):
    """16 meshed disks in a fixed box under gravity, with random velocities and friction."""
    r, h = 0.05, 0.02
    rock = fdem.Material(density=2500.0, young=1e8, poisson=0.25, friction=0.3)
    scene = fdem.Scene(gravity=(0.0, -9.81))
    width, height = 9 * r, 9 * r
    scene.add_body(fdem.mesh.rectangle(width + 2 * h, h, h), rock, position=(0.5 * width, -0.5 * h), fixed=True)
    scene.add_body(fdem.mesh.rectangle(h, height, h), rock, position=(-0.5 * h, 0.5 * height), fixed=True)
    scene.add_body(fdem.mesh.rectangle(h, height, h), rock, position=(width + 0.5 * h, 0.5 * height), fixed=True)
    rng = np.random.default_rng(seed)
    disk = fdem.mesh.disk(r, 0.4 * r)
    for j in range(4):
        for i in range(4):
            x = r + 2 * r * i + (r if j % 2 else 0.0)
            scene.add_body(disk, rock, position=(x, r + math.sqrt(3) * r * j), velocity=tuple(rng.normal(0, speed, 2)))
    return scene.build(strategy=strategy)


def _apart_distance(A: np.ndarray, B: np.ndarray) -> float:
    """The distance between two counter-clockwise triangles (3, 2); 0 when they overlap."""
    for T, P in ((A, B), (B, A)):
        for k in range(3):
            d = T[(k + 1) % 3] - T[k]
            n = np.array([d[1], -d[0]])
            if np.all((P - T[k]) @ n >= 0.0):
                break
        else:
            continue
        break
    else:
        return 0.0                                  # no separating edge normal: they overlap

    def point_segment(p, a, b):
        t = np.clip(np.dot(p - a, b - a) / np.dot(b - a, b - a), 0.0, 1.0)
        return float(np.linalg.norm(p - (a + t * (b - a))))

    return min(point_segment(P[i], T[k], T[(k + 1) % 3]) for P, T in ((A, B), (B, A))
               for i in range(3) for k in range(3))


@pytest.mark.parametrize("strategy", ["serial", "parallel"])
def test_every_certificate_holds(strategy):
    """At every check of a settling pile, each couple certified apart up to D_acc = s lies at a
    distance of at least s − D_acc (the bound the certificate keeps: its gap less the
    displacement since); and most apart couples are certified (the test is not vacuous)."""
    sim = _pile(strategy)
    tn = sim.model.tri_nodes.to_numpy()
    certified_total = 0
    for _ in range(6):
        sim.step(150)
        x = sim.node_positions()
        dacc = counter(sim.state.step_real, DACC)
        skip = sim.solver.scratch.couple_skip.to_numpy()[: sim.solver.couple_count]
        pairs = sim.couples()
        certified = np.nonzero(skip > dacc)[0]
        for c in certified:
            dist = _apart_distance(x[tn[pairs[c, 0]]], x[tn[pairs[c, 1]]])
            assert dist >= skip[c] - dacc - 1e-12, (c, dist, skip[c], dacc)
        certified_total += len(certified)
        assert len(certified) > 0.2 * len(pairs), (len(certified), len(pairs))
    assert certified_total > 0


def _trajectory(sim) -> dict:
    """The state's bits, and the friction work (summed in a fixed order by the kernels).  (The
    contact energy is left out: ``energies()`` sums it with atomic adds in a parallel loop, whose
    order, and last bits, vary from run to run.)"""
    return {"x": sim.node_positions().tobytes(), "v": sim.node_velocities().tobytes(),
            "hist": sim.state.couple_hist.to_numpy()[: 6 * sim.solver.couple_count].tobytes(),
            "friction": sim.energies()["friction"].hex()}


@pytest.mark.parametrize("strategy", ["serial", "parallel"])
def test_skipping_certified_couples_changes_no_bit(strategy):
    """300 steps of the pile in one launch (certificates used) and in 300 launches of one step
    (never used): the same positions, velocities, friction slips and energies, bit for bit."""
    a = _pile(strategy, speed=2.0)
    a.step(300)
    b = _pile(strategy, speed=2.0)
    for _ in range(300):
        b.step(1)
    assert a.solver.detection_count > 1
    assert _trajectory(a) == _trajectory(b)


def test_skipping_changes_no_bit_in_a_fragmenting_impact():
    """The same with joints breaking under an impact, friction and neighbour pairs
    (parallel strategy): 240 steps at once and in launches of one step."""
    from taichi_fdem.verification import fragment_plate_scene
    runs = []
    for per_launch in (240, 1):
        sim, _ = fragment_plate_scene(h_plate=0.025, h_ball=0.02, friction=0.5)
        sim = sim.scene.build(strategy="parallel")
        for _ in range(240 // per_launch):
            sim.step(per_launch)
        runs.append((_trajectory(sim), sim.cracks.broken_count, sim.state.tri_nb_on.to_numpy().tobytes()))
    assert runs[0][1] > 0
    assert runs[0] == runs[1]
