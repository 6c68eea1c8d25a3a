"""The renderer draws a simulation from its device arrays: the per-triangle damage, the colours of
a supersampled scalar frame and the triangles left by an excavation are computed by kernels, and
each equals a NumPy reference built on the host from the same state."""
import numpy as np

import taichi_fdem as fdem
from taichi_fdem import render
from taichi_fdem.render.colors import colormap

from conftest import build_quiet

ROCK = dict(density=2500.0, young=1e8, poisson=0.25, tensile_strength=1e5, cohesion=3e5, fracture_energy=5.0)


def _plate(fracture=True):
    """A jointed 0.2 m × 0.1 m plate, no gravity."""
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(0.2, 0.1, 0.04), fdem.Material(**ROCK), fracture=fracture, name="plate")
    return build_quiet(scene)


def test_damage_frame_equals_tri_damage():
    """The damage mode's scalars (a kernel over each triangle's joints) equal the host's
    ``sim.cracks.tri_damage()`` (np.maximum.at over the joints), for a random damage and broken set."""
    sim = _plate()
    nj = sim.model.joint_count
    assert nj > 10
    rng = np.random.default_rng(3)
    st = sim.state
    dmax = st.joint_dmax.to_numpy()
    dmax[:nj] = rng.uniform(0.0, 0.9, (nj, 3))
    st.joint_dmax.from_numpy(dmax)
    js = st.joint_state.to_numpy()
    js[:nj] = rng.uniform(size=nj) < 0.2
    st.joint_state.from_numpy(js)
    ref = sim.cracks.tri_damage()
    assert ref.max() == 1.0 and 0.0 < ref.min() < 1.0
    r = render.RendererImage(64, 32, color_by="damage", stamp=False, colorbar=False)
    r.render_sim(sim)
    np.testing.assert_array_equal(r.last_scalars, ref)


def test_supersampled_scalar_frame_equals_host_colours():
    """A supersampled speed frame (colours mapped on the device) equals the frame drawn from the
    host's :func:`colormap` of the same scalars (at most one level apart: f32 rounding)."""
    sim = _plate(fracture=False)
    x = sim.node_positions()
    sim.set_node_velocities(np.stack([x[:, 0] * 10.0, x[:, 1] * -5.0], axis=1))
    view = (-0.12, 0.12, -0.07, 0.07)
    r = render.RendererImage(96, 56, view=view, color_by="speed", supersample=2, vmin=0.0, vmax=1.0,
                             stamp=False, colorbar=False)
    img = r.render_sim(sim)
    ref = render.RendererImage(96, 56, view=view, supersample=2).render(
        sim.node_positions(), sim.model.tri_nodes_np, colormap(r.last_scalars, 0.0, 1.0, r.cmap))
    diff = np.abs(img.astype(int) - ref.astype(int))
    assert diff.max() <= 1, diff.max()
    assert len(np.unique(img.reshape(-1, 3), axis=0)) > 10      # a gradient, not one colour


def test_excavated_triangles_drawn_from_the_device_state():
    """After ``sim.remove``, the frame equals the frame of the remaining triangles alone."""
    sim = _plate(fracture=False)
    view = (-0.12, 0.12, -0.07, 0.07)
    r = render.RendererImage(96, 56, view=view, stamp=False, colorbar=False)
    full = r.render_sim(sim)
    assert sim.remove(where=lambda x, y: x > 0.02) > 0
    img = r.render_sim(sim)
    keep = sim.active_triangles()
    ref = render.RendererImage(96, 56, view=view).render(
        sim.node_positions(), sim.model.tri_nodes_np[keep], render.body_colors(sim.model.tri_body_np[keep]))
    np.testing.assert_array_equal(img, ref)
    assert (img != full).any()
