"""Tiny scenes run on one device, for comparing the GPU path (arch="vulkan") with the CPU.

Run as ``python tests/gpu_probe.py ARCH PRECISION``: prints one JSON line, a dict keyed by
case with the final positions [m], the couples, the broken joints, the energy terms, the
crack events, the fragments, a rendered frame's mean colour, three frames (body with cracks,
damage, and the supersampled speed of a velocity field set from the rest positions) and a checkpoint round trip (the state arrays as loaded, and the
positions after stepping on).
Every case uses ``strategy="parallel"`` with the slot assembly (the GPU default), so that the
CPU run is the same algorithm.  A separate process: Taichi is initialised once per process.

Cases (the features each runs):

* ``impact``: a brittle plate (every interior edge a cohesive joint) hit by a disc, friction
  0.5: contact, friction, detection, fracture, crack events, fragments, energies, renderer,
  checkpoint.
* ``rock``: a gravity-loaded block on a fixed floor with an initial stress, Weibull joint
  strength on a jointed body plus a joint set on a line, a pre-existing crack, a pressure on
  its top under a ramp curve, an absorbing bottom boundary and local damping, then an
  excavation (``sim.remove``) half-way: heterogeneity, joint sets, cracks, loads and curves,
  absorbing boundaries, initial stress, local damping, excavation.
* ``fluid``: a jointed block with a central crack fed by a rate source, drained by a pressure
  source at one of its edges: the fluid in the fracture network (apertures, pressures, the
  pressure forces and their gather, the flow substeps, joints that break and join the network).
* ``heat``: a jointed block heated by a ramped held temperature on one edge and a flux on
  another: heat conduction through the triangles and the joints (engine.heat), the curves of
  its rows, the thermal strains and their work.
"""
import json
import os
import sys
import tempfile

import numpy as np

import taichi_fdem as fdem

STEPS = 120


def impact_scene():
    from taichi_fdem.verification import fragment_plate_scene
    sim, _ = fragment_plate_scene(h_plate=0.025, h_ball=0.02, friction=0.5)
    return sim.scene


def rock_scene():
    rock = fdem.Material(density=2500.0, young=1e8, poisson=0.25, friction=0.4, tensile_strength=2e4,
                         fracture_energy=5.0, name="rock")
    weak = fdem.Material(density=2500.0, young=1e8, poisson=0.25, friction=0.3, tensile_strength=5e3,
                         fracture_energy=1.0, name="joint")
    scene = fdem.Scene(gravity=(0.0, -9.81))
    scene.add_body(fdem.mesh.rectangle(0.4, 0.04, 0.04), rock, position=(0.0, -0.02), fixed=True, name="floor")
    block = scene.add_body(fdem.mesh.rectangle(0.2, 0.1, 0.025), rock, position=(-0.1, 0.0501),
                           fracture=True, strength=fdem.Weibull(4.0, seed=2), name="block")
    scene.add_joint_set("line", lambda x, y: np.abs(y - 0.0501) < 1e-6, weak, body=block)
    other = scene.add_body(fdem.mesh.rectangle(0.15, 0.1, 0.025), rock, position=(0.1, 0.0501),
                           cracks=lambda x, y: np.abs(x - 0.1) < 1e-6, name="cracked")
    scene.initial_stress(-2e4, -1e4, 0.0, body=other)
    scene.initial_stress(-2e3, -1e3, 5e2, body=block)       # carried by the block's joints too
    scene.apply_pressure(lambda x, y: y > 0.1, 2e4, body=block, curve=fdem.Curve.ramp(1e-3))
    scene.absorbing_boundary(lambda x, y: y < -0.039, body=None)
    return scene


def fluid_scene():
    rock = fdem.Material(density=2700.0, young=10e9, poisson=0.25, tensile_strength=3e5, cohesion=9e5,
                         fracture_energy=1.0, friction=0.3)
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(0.2, 0.2, 0.05), rock, fracture=True,
                   cracks=lambda x, y: (np.abs(y) < 1e-9) & (np.abs(x) < 0.06))
    scene.set_fluid(fdem.Fluid(bulk_modulus=1e8), aperture_min=1e-5)
    scene.inject(lambda x, y: (np.abs(x) < 1e-9) & (np.abs(y) < 1e-9), rate=2e-2)
    scene.inject(lambda x, y: (np.abs(x - 0.05) < 1e-9) & (np.abs(y) < 1e-9), pressure=0.0)
    return scene


def _hot_edge(x, y):
    return x < -0.1 + 1e-9


def _top_edge(x, y):
    return y > 0.1 - 1e-9


def _warm_block(x, y):
    return np.where(x > 0.1 + 1e-6, 120.0, 20.0)


def heat_scene():
    rock = fdem.Material(density=2700.0, young=1e8, poisson=0.25, tensile_strength=3e5, cohesion=9e5,
                         fracture_energy=1.0, conductivity=3.0, heat_capacity=800.0, expansion=1e-5)
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(0.2, 0.2, 0.05), rock, fracture=True, velocity=(2.0, 0.0))
    # a warm block the rock runs into: contact conduction
    scene.add_body(fdem.mesh.rectangle(0.05, 0.2, 0.05, origin=(0.1, -0.1)), rock, fixed=True)
    scene.set_temperature(_warm_block)
    scene.heat(_hot_edge, temperature=220.0, curve=fdem.Curve.ramp(1e-4))
    scene.heat(_top_edge, flux=1e6)
    return scene


def snapshot(sim, arch):
    from taichi_fdem.render import RendererImage
    e = sim.energies()
    ev = sim.cracks.events()
    fr = sim.cracks.fragments()
    img = RendererImage(width=96, height=64).render_sim(sim)
    frames = {"body_cracks": RendererImage(width=96, height=64, cracks=True).render_sim(sim),
              "damage": RendererImage(width=96, height=64, color_by="damage").render_sim(sim)}
    out = {"x": sim.node_positions().tolist(), "couples": sorted(map(list, {(int(min(a, b)), int(max(a, b)))
                                                                         for a, b in sim.couples()})),
           "broken": int(sim.cracks.broken_count), "energies": {k: float(v) for k, v in e.items()},
           "events": int(len(ev["index"])), "event_joints": sorted(int(i) for i in ev["index"]),
           "fragments": int(fr["count"]), "image_mean": float(np.asarray(img, dtype=np.float64).mean()),
           "image_shape": list(np.shape(img)), "device": sim.info().get("device", arch),
           "frames": {k: np.asarray(v).tolist() for k, v in frames.items()}}
    # the speed colours of a velocity field set from the rest positions (the same on every device,
    # unlike the f32 velocities of the run), through the supersampled path: the device's colour map
    X = np.asarray(sim.model.node_rest, dtype=np.float64)
    sim.set_node_velocities(np.stack([4.0 * (X[:, 0] - X[:, 0].min()), -2.0 * (X[:, 1] - X[:, 1].min())], axis=1))
    out["frames"]["speed_ss2"] = RendererImage(width=96, height=64, color_by="speed", supersample=2, vmin=0.0,
                                               vmax=2.0, colorbar=False).render_sim(sim).tolist()
    return out


def state_arrays(sim) -> dict:
    """Every Taichi array of the state, as NumPy (step_int without its REBALANCE slot, which a
    load resets to redo the block split)."""
    from taichi_fdem.engine.groups import REBALANCE
    out = {k: v.to_numpy() for k, v in vars(sim.state).items() if hasattr(v, "to_numpy")}
    out["step_int"][REBALANCE] = 0
    return out


def run_case(name, arch):
    scene = {"impact": impact_scene, "rock": rock_scene, "fluid": fluid_scene, "heat": heat_scene}[name]()
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        sim = scene.build(strategy="parallel", quasi_static=(0.3 if name == "rock" else False))
    sim.solver.assembly = os.environ.get("FDEM_PROBE_ASSEMBLY", "slots")
    sim.step(STEPS // 2)
    if name == "rock":
        sim.remove(where=lambda x, y: (x > 0.12) & (y > 0.06))
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "c.fdem")
        sim.save(path)
        saved = state_arrays(sim)
        sim.step(STEPS // 2)
        back = fdem.Simulation.load(path)
        loaded = state_arrays(back)
        state_same = sorted(saved) == sorted(loaded) and all(
            saved[k].shape == loaded[k].shape and np.array_equal(saved[k], loaded[k]) for k in saved)
        back.solver.assembly = sim.solver.assembly
        back.step(STEPS // 2)
        same = bool(np.array_equal(back.node_positions(), sim.node_positions()))
    out = snapshot(sim, arch)
    out["checkpoint_same"] = same
    if name == "fluid":
        out["fluid_pressures"] = sim.fluid.pressures()[1].tolist()
        out["injected"] = sim.fluid.injected_volumes().tolist()
    if name == "heat":
        out["temperatures"] = sim.temperatures().tolist()
    out["checkpoint_state_same"] = bool(state_same)
    return out


def main(arch, precision, cases):
    fdem.init(arch=arch, precision=precision)
    print(json.dumps({c: run_case(c, arch) for c in cases}))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3].split(",") if len(sys.argv) > 3 else ["impact", "rock", "fluid", "heat"])
