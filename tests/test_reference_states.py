"""Reference states: three scenes (a fracturing impact, a fluid-driven fracture, a loaded rock
mass) run by each strategy must end in the states stored in ``tests/data/reference_states.npz``,
bit for bit.  The stored states are the engine's own output at a fixed version; the test holds
refactorings of the engine to the same arithmetic.  Regenerate them (only on purpose, when the
arithmetic is meant to change) with ``python tests/test_reference_states.py``.

Bits depend on the host as well as on the code: Taichi compiles for the host CPU with fast math
(fused multiply-adds, vector width) and NumPy's transcendental functions pick per-CPU SIMD
code.  The file records the host that wrote it (:func:`host_signature`); on that host the test
compares bit for bit, on any other it compares the counters exactly and the real arrays to
``ROUND_OFF`` relative to each array's scale, and says so in the assertion messages."""
from __future__ import annotations

import pathlib
import platform
import sys

import numpy as np
import pytest

import taichi_fdem as fdem

DATA = pathlib.Path(__file__).parent / "data" / "reference_states.npz"
STRATEGIES = ("serial", "parallel")
#: relative tolerance (to each array's largest magnitude) of the comparison on another host
ROUND_OFF = 1e-5


def host_signature() -> str:
    """What the bits of a run depend on besides the code: CPU, its vector extensions, versions."""
    model, flags = platform.processor(), set()
    try:
        for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines():
            key, _, value = line.partition(":")
            if key.strip() == "model name":
                model = value.strip()
            elif key.strip() == "flags":
                flags = set(value.split())
                break
    except OSError:
        pass
    simd = ",".join(sorted(f for f in flags if f.startswith(("avx", "fma", "sse4"))))
    import taichi
    return f"{platform.machine()}|{model}|{simd}|taichi {taichi.__version__}|numpy {np.__version__}"


def fracturing_scene():
    """A ball hitting a jointed plate: joints break, couples appear, friction slips."""
    from taichi_fdem.verification import fragment_plate_scene
    sim, _ = fragment_plate_scene(h_plate=0.025, h_ball=0.02, friction=0.5)
    return sim.scene, 0.002


def fluid_scene():
    """A jointed block fed at its centre crack at a constant rate: the fluid opens the crack."""
    rock = fdem.Material(density=2700.0, young=10e9, poisson=0.25, tensile_strength=3e5, cohesion=9e5,
                         fracture_energy=1.0)
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(0.4, 0.4, 0.05), rock, fracture=True,
                   cracks=lambda x, y: (np.abs(y) < 1e-9) & (np.abs(x) < 0.06))
    scene.set_fluid(fdem.Fluid(bulk_modulus=1e8), aperture_min=1e-5, conduct="broken")
    scene.inject(lambda x, y: (np.abs(x) < 1e-9) & (np.abs(y) < 1e-9), rate=2e-2)
    return scene, 200


def loaded_rock_scene():
    """A prestressed jointed rock block under gravity on a fixed base, pressed by a ramped
    pressure and a traction, one side pushed at a prescribed velocity, one absorbing."""
    rock = fdem.Material(density=2600.0, young=20e9, poisson=0.2, tensile_strength=2e6, cohesion=6e6,
                         friction_angle=35.0, fracture_energy=20.0, damping=0.2)
    scene = fdem.Scene(gravity=(0.0, -9.81))
    body = scene.add_body(fdem.mesh.rectangle(0.5, 0.3, 0.04), rock, fracture=True)
    scene.initial_stress(-1e6, -2e6, 1e5, body=body)
    ramp = fdem.Curve.ramp(2e-4)
    scene.fix_nodes(lambda x, y: y < -0.15 + 1e-9, body=body)
    scene.fix_nodes(lambda x, y: x < -0.25 + 1e-9, body=body, velocity=(0.05, 0.0))
    scene.apply_pressure(lambda x, y: y > 0.15 - 1e-9, 3e6, body=body, curve=ramp)
    scene.apply_traction(lambda x, y: x > 0.25 - 1e-9, (0.0, 1e5), body=body)
    return scene, 300


SCENES = {"fracturing": fracturing_scene, "fluid": fluid_scene, "loaded": loaded_rock_scene}


def run(name: str, strategy: str) -> dict:
    """Run scene ``name`` with ``strategy``: its final arrays and counters."""
    scene, amount = SCENES[name]()
    sim = scene.build(strategy=strategy)
    if isinstance(amount, float):
        sim.run(amount, progress=False)
    else:
        sim.step(amount)
    e = sim.energies()
    out = {"x": sim.node_positions(), "v": sim.node_velocities(), "time": np.float64(sim.time),
           "broken": np.int64(sim.cracks.broken_count), "couples": np.int64(sim.solver.couple_count),
           "energies": np.array([e[k] for k in sorted(e)], np.float64)}
    return out


@pytest.fixture(scope="module")
def reference():
    if not DATA.exists():
        pytest.fail(f"{DATA} is missing: run python {__file__} to write it")
    with np.load(DATA) as z:
        return {k: z[k] for k in z.files}


def same_host(reference) -> bool:
    return "host" in reference and str(reference["host"]) == host_signature()


@pytest.mark.parametrize("strategy", STRATEGIES)
@pytest.mark.parametrize("name", list(SCENES))
def test_final_state_matches_the_stored_reference_bit_for_bit(reference, name, strategy):
    got = run(name, strategy)
    if name == "fracturing":
        assert got["broken"] > 0 and got["couples"] > 0
    bitwise = same_host(reference)
    for key, value in got.items():
        ref = reference[f"{name}/{strategy}/{key}"]
        value = np.asarray(value)
        assert value.shape == ref.shape and value.dtype == ref.dtype, (name, strategy, key)
        if bitwise or value.dtype.kind in "iu":
            assert value.tobytes() == ref.tobytes(), f"{name}/{strategy}: {key} differs from the stored reference"
        else:
            scale = max(float(np.abs(ref).max()), np.finfo(float).tiny)
            err = float(np.abs(value - ref).max()) / scale
            assert err <= ROUND_OFF, (f"{name}/{strategy}: {key} differs from the reference written on "
                                      f"{str(reference.get('host', 'an unrecorded host'))!r} by {err:.3g} of its "
                                      f"scale (this host: {host_signature()!r}, compared to round-off)")


if __name__ == "__main__":
    fdem.init()
    arrays = {}
    for scene_name in SCENES:
        for strat in STRATEGIES:
            for k, val in run(scene_name, strat).items():
                arrays[f"{scene_name}/{strat}/{k}"] = np.asarray(val)
            print(scene_name, strat, "done", file=sys.stderr)
    np.savez_compressed(DATA, host=np.array(host_signature()), **arrays)
    print(f"wrote {DATA}")
