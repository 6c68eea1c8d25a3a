"""Heat conduction across contacts between triangles that share no joint (docs/theory/heat.md
§16.4): two bodies pressed together conduct like one (Carslaw & Jaeger's two half-spaces), the
conductance follows the stated law of the overlap, bodies apart conduct nothing, the heat is
conserved, and every strategy gives the same bits."""
import math

import numpy as np
import pytest
from scipy.special import erfc

import taichi_fdem as fdem
from taichi_fdem.engine.heat import CONTACT_OVERLAP_REF, JOINT_CONDUCTANCE_FACTOR

fdem.init(arch="cpu")

S = 0.0125          # element size [m]
H = 0.05            # height of the bars [m]
KAPPA = 1e-3        # k / (ρ c) [m²/s]


def _mat():
    return fdem.Material(density=1000.0, young=1e3, poisson=0.25, conductivity=1.0, heat_capacity=1.0)


def _two_bars(overlap, strategy="serial"):
    """Bar "hot" on [0, 0.5] at 1 K, held still, and bar "cold" on [0.5 − overlap, 1 − overlap] at
    0 K, held still but for its far end (so that the pair is not one of two fixed bodies, which
    do not contact): they press together over the height H with the given overlap [m] (negative:
    a gap).  Without expansion nothing moves."""
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(0.5, H, S, origin=(0.0, 0.0)), _mat(), fixed=True, name="hot")
    cold = scene.add_body(fdem.mesh.rectangle(0.5, H, S, origin=(0.5 - overlap, 0.0)), _mat(), name="cold")
    scene.fix_nodes(lambda x, y: x < 0.99 - overlap, body=cold)
    scene.set_temperature(lambda x, y: np.where(x < 0.5 - 0.5 * overlap, 1.0, 0.0))
    with pytest.warns(RuntimeWarning, match="overlap") if overlap > 0 else _nothing():
        return scene.build(strategy=strategy)


class _nothing:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def _stored(sim):
    return float(np.sum(sim.model.heat_capacity_np * sim.temperatures()))


def test_bodies_in_contact_conduct_like_two_half_spaces():
    """Two bars at 1 K and 0 K pressed together (overlap 2e-3 of the element size: a closed
    contact): T = ½ (1 ± erf(|x − x_c| / (2√(κt)))) on either side of the contact x_c (Carslaw &
    Jaeger §2.15, two equal half-spaces in perfect contact) within 1 % of the difference, and the
    stored heat is conserved to 1e-12."""
    sim = _two_bars(2e-3 * S)
    Q0 = _stored(sim)
    sim.step(int(round(4.0 / sim.dt)))
    t = sim.solver.heat.time
    assert t > 3.9
    xi = sim.model.node_rest[:, 0] - 0.5
    z = np.abs(xi) / (2.0 * math.sqrt(KAPPA * t))
    ref = np.where(xi < 0, 1.0 - 0.5 * erfc(z), 0.5 * erfc(z))
    T = sim.temperatures()
    err = np.abs(T - ref).max()
    assert err < 0.01, err
    assert T[xi > 0].max() > 0.4                        # the heat did cross
    assert abs(_stored(sim) - Q0) < 1e-12 * abs(Q0)


def _conductances(sim):
    """(G_c of the conducting couples, weights on their triangles' nodes) after the last heat
    update."""
    v = sim._scratch.heat_cpl.to_numpy()[: sim.state.counters.couples]
    on = v[:, 0] > 0
    return v[on, 0], v[on, 1:]


@pytest.mark.parametrize("share", [0.25, 1.0, 2.0])
def test_contact_conductance_follows_the_overlap_law(share):
    """Faces pressed over the height H with an overlap δ: the couples' conductances add up to
    F k H / h̄ · min(1, δ / (r s)) (docs/theory/heat.md §16.4: the potential along the face is
    3δ/s, the altitude of the face s; h̄ = s/√2 the smallest altitude), within 1 %; the weights
    of each contact point sum to 1 on each triangle."""
    delta = share * CONTACT_OVERLAP_REF * S
    sim = _two_bars(delta)
    sim.step(sim.solver.heat.every())
    assert sim.solver.heat.updates == 1
    G, w = _conductances(sim)
    expect = JOINT_CONDUCTANCE_FACTOR * 1.0 * H / (S / math.sqrt(2.0)) * min(1.0, share)
    assert abs(G.sum() / expect - 1.0) < 0.01, (G.sum(), expect)
    assert np.allclose(w[:, :3].sum(axis=1), 1.0) and np.allclose(w[:, 3:].sum(axis=1), 1.0)
    assert np.all(w >= 0.0)


def test_bodies_apart_conduct_nothing():
    """A gap of 1e-4 m: no contact conducts, the cold bar stays at 0 K exactly."""
    sim = _two_bars(-1e-4)
    sim.step(2 * sim.solver.heat.every() + 3)
    xi = sim.model.node_rest[:, 0] - 0.5
    T = sim.temperatures()
    assert np.all(T[xi > 0] == 0.0) and np.all(T[xi < 0] == 1.0)
    assert len(_conductances(sim)[0]) == 0


def test_contact_conduction_is_the_same_bits_for_every_strategy():
    """The serial strategy (all heat steps in one launch) and the parallel one (a launch per
    heat step, the contact lists filled in parallel and sorted) give the same temperatures bit
    for bit."""
    runs = []
    for strategy in ("serial", "parallel"):
        sim = _two_bars(2e-3 * S, strategy=strategy)
        sim.step(3 * sim.solver.heat.every() + 5)
        runs.append(sim.temperatures())
    assert np.array_equal(runs[0], runs[1])
    assert runs[0][sim.model.node_rest[:, 0] > 0.5].max() > 0.0
