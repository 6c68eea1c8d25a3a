"""Strength of the bedding (docs/theory/anisotropy.md): the joint strength law by the angle to the
bedding, weak bedding planes, lab tests at a bedding angle, Jaeger's plane of weakness, the
anisotropic Brazilian disc and a fluid-driven fracture in bedded rock."""
import math

import numpy as np
import pytest

import taichi_fdem as fdem
from taichi_fdem.discontinuity import BEDDING_WINDOW, bedding_strength, bedding_weight
from taichi_fdem.lab.specimens import jaeger_peak

E, NU = 20e9, 0.2
#: an elastically isotropic bedding (E2 = E1, ν21 = ν1, G2 = E/2(1 + ν)): its strength alone differs
ISO = dict(young_normal=E, poisson_normal=NU, shear_modulus=E / (2 * (1 + NU)))
WEAK = dict(tensile_strength=2e6, cohesion=4e6, friction_angle=25.0, fracture_energy=20.0)


def rock(**bedding):
    bed = fdem.Bedding(**{**ISO, **WEAK, **bedding}) if bedding else None
    return fdem.Material(density=2600.0, young=E, poisson=NU, tensile_strength=8e6, cohesion=24e6,
                         friction_angle=35.0, fracture_energy=50.0, bedding=bed)


def joint_angles(body, dip):
    """Angle [°] between each joint of ``body`` and the bedding of dip ``dip`` [°]."""
    p = body.mesh.points
    d = p[body.joint_nodes[:, 1]] - p[body.joint_nodes[:, 0]]
    t = np.array([math.cos(math.radians(dip)), math.sin(math.radians(dip))])
    return np.degrees(np.arccos(np.clip(np.abs(d @ t) / np.linalg.norm(d, axis=1), 0, 1)))


# ---------------------------------------------------------------------------- the law
def test_weight_is_one_parallel_zero_across_and_monotone():
    th = np.linspace(0.0, 90.0, 181)
    w = bedding_weight(th, 30.0)
    assert w[0] == 1.0 and w[-1] == 0.0
    assert np.all(np.diff(w) <= 0.0)
    assert np.all(w[th >= 30.0] == 0.0)
    assert bedding_weight(45.0, 90.0) == pytest.approx(0.5)


def test_parallel_joints_get_the_bedding_across_the_material_monotone_between():
    m = rock(angle=30.0, fracture_energy_shear=100.0, strength_window=40.0)
    body = fdem.Scene().add_body(fdem.mesh.disk(0.05, 0.005), m, fracture=True)
    th = joint_angles(body, 30.0)
    jp = body.joint_prop
    ft, c, tphi, g1, g2 = jp[:, 0], jp[:, 1], jp[:, 2], jp[:, 3], jp[:, 4]
    mat = np.array(rock().joint_properties())
    across = th >= 40.0
    assert across.any() and np.allclose(jp[across, :5], mat[:5])
    par = th < 1e-6
    if par.any():
        assert np.allclose(ft[par], 2e6) and np.allclose(c[par], 4e6)
    # monotone in θ: each parameter rises from the bedding's to the material's value
    order = np.argsort(th)
    for col in (ft, c, tphi, g1, g2):
        assert np.all(np.diff(col[order]) >= -1e-9 * col.max())
    # the law itself at θ = 0 and at the window's middle
    row = bedding_strength(mat[None].repeat(2, 0), m.bedding, np.array([0.0, 20.0]))
    assert row[0, :5] == pytest.approx([2e6, 4e6, math.tan(math.radians(25.0)), 20.0, 100.0])
    assert row[1, 0] == pytest.approx(0.5 * (2e6 + 8e6))
    assert row[1, 2] == pytest.approx(math.tan(math.radians(30.0)))        # φ interpolated, then tan
    assert np.all(row[:, 5] == mat[5])                                     # the joint penalty is kept


def test_default_window_and_isotropic_parameters():
    """None in the Bedding keeps the material's value; the default window is BEDDING_WINDOW."""
    m = rock(angle=0.0, tensile_strength=None, cohesion=None, friction_angle=None, fracture_energy=None)
    body = fdem.Scene().add_body(fdem.mesh.rectangle(0.1, 0.05, 0.01), m, fracture=True)
    assert np.allclose(body.joint_prop, np.array(rock().joint_properties()))
    m = rock(angle=0.0)
    assert bedding_strength(np.array([m.joint_properties()]), m.bedding, np.array([0.5 * BEDDING_WINDOW]))[0, 0] \
        == pytest.approx(5e6)


def test_statistical_strength_still_multiplies():
    m = rock(angle=0.0)
    sc = fdem.Scene()
    plain = sc.add_body(fdem.mesh.rectangle(0.1, 0.05, 0.01), m, fracture=True)
    spread = sc.add_body(fdem.mesh.rectangle(0.1, 0.05, 0.01), m, fracture=True, position=(1, 0),
                         strength=fdem.Weibull(4.0, seed=3))
    f = spread.joint_prop[:, 0] / plain.joint_prop[:, 0]
    assert np.allclose(spread.joint_prop[:, 1] / plain.joint_prop[:, 1], f)
    assert f.std() > 0.1


def test_callable_angle_follows_the_position():
    m = rock(angle=lambda x, y: np.where(x < 0, 0.0, 90.0), strength_window=10.0)
    body = fdem.Scene().add_body(fdem.mesh.rectangle(0.2, 0.1, 0.01), m, fracture=True)
    p = body.mesh.points
    mid = 0.5 * (p[body.joint_nodes[:, 0]] + p[body.joint_nodes[:, 1]])
    d = p[body.joint_nodes[:, 1]] - p[body.joint_nodes[:, 0]]
    horiz = np.abs(d[:, 1]) < 1e-9 * np.abs(d).max()
    vert = np.abs(d[:, 0]) < 1e-9 * np.abs(d).max()
    left, right = mid[:, 0] < -0.02, mid[:, 0] > 0.02
    assert np.allclose(body.joint_prop[horiz & left, 0], 2e6) and np.allclose(body.joint_prop[vert & left, 0], 8e6)
    assert np.allclose(body.joint_prop[vert & right, 0], 2e6) and np.allclose(body.joint_prop[horiz & right, 0], 8e6)


# ---------------------------------------------------------------------------- weak bedding planes
def test_bedding_lines_of_a_box_a_polygon_and_a_mesh():
    box = (-0.05, -0.1, 0.05, 0.1)
    lines = fdem.mesh.bedding_lines(box, 0.0, 0.02)
    assert len(lines) == 9 and lines.length == pytest.approx(9 * 0.1)       # y = ±0.1 run along the box
    lines = fdem.mesh.bedding_lines(box, 90.0, 0.03, origin=(0.01, 0.0))
    assert sorted(np.round(lines.segments[:, 0, 0], 12)) == pytest.approx([-0.02, 0.01, 0.04])
    ring = fdem.mesh.annulus(0.02, 0.05, 0.005)
    lines = fdem.mesh.bedding_lines(ring, 0.0, 0.1)                         # through the hole: two pieces
    assert len(lines) == 2
    assert fdem.mesh.bedding_lines(box, 0.0, 1.0, origin=(0.0, 0.5)) is None
    with pytest.raises(ValueError, match="spacing must be > 0"):
        fdem.mesh.bedding_lines(box, 0.0, 0.0)
    with pytest.raises(ValueError, match="region must be"):
        fdem.mesh.bedding_lines([(0, 0), (1, 1)], 0.0, 0.1)


def test_spaced_bedding_makes_a_joint_set_with_exactly_the_bedding_strength():
    verts = [(-0.05, -0.05), (0.05, -0.05), (0.05, 0.05), (-0.05, 0.05)]
    lines = fdem.mesh.bedding_lines(verts, 30.0, 0.02)
    mesh = fdem.mesh.polygon(verts, 0.01, lines=[lines])
    m = rock(angle=30.0, spacing=0.02, strength_window=60.0)
    sc = fdem.Scene()
    body = sc.add_body(mesh, m, fracture=True)
    assert sc.joint_set_names == ["default", "bedding"]
    on = body.joint_set == 1
    p = body.mesh.points
    length = np.linalg.norm(p[body.joint_nodes[on, 1]] - p[body.joint_nodes[on, 0]], axis=1).sum()
    assert length == pytest.approx(lines.length)
    assert np.allclose(body.joint_prop[on, :4], [2e6, 4e6, math.tan(math.radians(25.0)), 20.0])
    # the other joints follow the law
    th = joint_angles(body, 30.0)
    law = bedding_strength(np.array([rock().joint_properties()] * int((~on).sum())), m.bedding, th[~on])
    assert np.allclose(body.joint_prop[~on], law)
    # a mesh that does not follow the planes is refused
    with pytest.raises(ValueError, match="do not follow the bedding planes"):
        fdem.Scene().add_body(fdem.mesh.polygon(verts, 0.01), m, fracture=True)
    with pytest.raises(ValueError, match="constant angle"):
        fdem.Scene().add_body(mesh, rock(angle=lambda x, y: 0 * x, spacing=0.02), fracture=True)


# ---------------------------------------------------------------------------- lab tests at a bedding angle
def test_bedding_angle_needs_a_bedding_and_a_number():
    with pytest.raises(ValueError, match="needs a material with a bedding"):
        fdem.lab.ucs(rock(), 0.05, 0.1, 0.0125, bedding_angle=30.0)
    with pytest.raises(ValueError, match="needs a material with a bedding"):
        fdem.lab.brazilian(rock(), 0.05, 0.005, bedding_angle=30.0)
    with pytest.raises(ValueError, match="bedding_angle must be a finite angle"):
        fdem.lab.triaxial(rock(angle=0.0), 0.05, 0.1, 0.0125, 1e6, bedding_angle=float("nan"))


def test_jaeger_formula():
    tp = math.tan(math.radians(25.0))
    s = jaeger_peak(5e6, 4e6, 25.0, 45.0)
    assert s - 5e6 == pytest.approx(2 * (4e6 + 5e6 * tp) / (1 - tp))
    assert jaeger_peak(5e6, 4e6, 25.0, 20.0) == math.inf and jaeger_peak(5e6, 4e6, 25.0, 90.0) == math.inf
    b = np.linspace(26, 89, 500)
    v = [jaeger_peak(5e6, 4e6, 25.0, x) for x in b]
    assert b[int(np.argmin(v))] == pytest.approx(45 + 12.5, abs=0.2)     # the weakest plane: β = 45° + φ/2
