"""The portable transcendental functions (taichi_fdem.engine.fmath) against numpy in both
precisions, and the strain energy near F = I against a 60-digit evaluation of its formula."""

import json
import os
import subprocess
import sys
from decimal import Decimal, getcontext

import numpy as np
import pytest
import taichi as ti

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

# max error [ulp] allowed per function (measured: ≤ 2.1 / 1.1 / 3.0 / 6.0 / 3.2 / 3.8)
BOUNDS = {"log": 3.0, "exp": 2.0, "log1p": 4.0, "log1p_minus": 8.0, "ipow6": 4.0, "pow": 5.0}


def run_probe(script: str, arch: str, precision: str, timeout: float = 600) -> dict:
    """The JSON line a probe script in tests/ prints, run in a fresh process."""
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    r = subprocess.run([sys.executable, os.path.join(HERE, script), arch, precision], capture_output=True,
                       text=True, timeout=timeout, env=env)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("precision", ["f64", "f32"])
def test_fmath_error_against_numpy_cpu(precision):
    """log over [e^-700, e^700] (f64) / [e^-80, e^80] (f32), exp over [−20, 20] / [−4, 4],
    log1p and d − log1p(d) over (−0.9, 3) and near 0, (1 − D)^6, x^2.5: within a few ulp."""
    err = run_probe("fmath_probe.py", "cpu", precision)
    for name, bound in BOUNDS.items():
        assert err[name] <= bound, (name, err[name])


def _w_reference(F, mu, lam):
    """W = ½μ(tr C − 2) − μ ln J + λ(½J² − ln J − ½) in 60-digit decimal arithmetic."""
    getcontext().prec = 60
    f = [[Decimal(float(F[i, j])) for j in range(2)] for i in range(2)]
    mu, lam = Decimal(mu), Decimal(lam)
    trC = sum(f[i][j] * f[i][j] for i in range(2) for j in range(2))
    J = f[0][0] * f[1][1] - f[0][1] * f[1][0]
    lnJ = J.ln()
    return float(Decimal("0.5") * mu * (trC - 2) - mu * lnJ + lam * (Decimal("0.5") * J * J - lnJ - Decimal("0.5")))


def test_strain_energy_near_identity():
    """W(F) for F = I + H, |H| from 1e-9 to 0.3 (and a pure rotation, W = 0): relative error
    ≤ 1e-13 against the formula evaluated to 60 digits, where ln J next to 1 would give none."""
    from taichi_fdem.engine.elastic import strain_energy_density
    rng = np.random.default_rng(3)
    Fs = []
    for scale in (1e-9, 1e-7, 1e-5, 1e-3, 1e-1, 0.3):
        for _ in range(4):
            Fs.append(np.eye(2) + scale * rng.uniform(-1.0, 1.0, (2, 2)))
    c, s = np.cos(0.3), np.sin(0.3)
    Fs.append(np.array([[c, -s], [s, c]]))
    Fs = np.array(Fs)
    mu, lam = 4.0e9, 6.0e9

    @ti.kernel
    def run(F: ti.types.ndarray(), out: ti.types.ndarray()):
        for i in range(F.shape[0]):
            M = ti.Matrix([[F[i, 0, 0], F[i, 0, 1]], [F[i, 1, 0], F[i, 1, 1]]], dt=ti.f64)
            out[i] = strain_energy_density(M, M.determinant(), mu, lam)

    out = np.zeros(len(Fs))
    run(Fs, out)
    for F, w in zip(Fs[:-1], out[:-1]):
        ref = _w_reference(F, mu, lam)
        assert abs(w - ref) <= 1e-13 * abs(ref), (F, w, ref)
    assert abs(out[-1]) <= 1e-20 * mu          # rotation: round-off of cos² + sin² only


def test_pile_strain_energy_at_rest_cpu():
    """A pile of disks at rest, undeformed: strain energy ≈ 0 (f64: < 1e-20 J/m; f32: < 1e-5 J/m,
    the size of f32 rounding of F: (ε·L/h)² E A ~ 1e-6 J/m here, against ~1e-3 J/m of the pile's
    strain energy at equilibrium under gravity); never negative (every term of W is ≥ 0)."""
    e64 = run_probe("pile_energy_probe.py", "cpu", "f64")
    e32 = run_probe("pile_energy_probe.py", "cpu", "f32")
    assert 0.0 <= e64["strain0"] < 1e-20 and 0.0 <= e64["strain200"] < 1e-18   # free fall: no strain
    assert 0.0 <= e32["strain0"] < 1e-5 and 0.0 <= e32["strain200"] < 1e-4
