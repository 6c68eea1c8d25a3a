"""Result objects of the lab tests, elastic constants from a curve, the quasi-static check and the
failure-envelope fits (Mohr–Coulomb, Hoek–Brown)."""
from __future__ import annotations

import csv
import math
import warnings
from dataclasses import dataclass, field

import numpy as np

#: The loading must reach the expected peak in at least this many P-wave transits of the
#: specimen (height / c_p, or D / c_p of a disc); faster is refused (ValueError).
MIN_TRANSITS = 10.0
#: Specimen kinetic energy / strain energy at half the peak above which a run warns that it was
#: not quasi-static (RuntimeWarning).
MAX_KINETIC_RATIO = 0.05
#: Joint penalty p_f of a lab specimen whose material leaves it unset, in units of the
#: material's E (``Material``'s own default is 10 E).  Intact joints add a compliance L/p_f
#: beside each element's h/E and their end-point tractions scatter about the continuum stress,
#: so that at 10 E the first joints reach f_t well before the continuum does.  The time step
#: shrinks as 1/√p_f.
JOINT_PENALTY_FACTOR = 50.0
#: The same for the compression tests (``ucs``, ``triaxial``, ``compression``): their E and ν
#: come from the whole specimen's compliance, to which every intact joint adds; at 200 E a
#: specimen with joints on every edge has the material's E and ν to 3 % (tests/test_lab.py).
COMPRESSION_JOINT_PENALTY_FACTOR = 200.0
#: ``check=`` values of the lab tests: which convergence reruns to make.
CHECKS = (None, "rate", "mesh", "both")


@dataclass
class LabResult:
    """One lab test's result.

    ``test``: its name ("ucs", "triaxial", "brazilian", "direct_shear"); ``curve``: named
    columns (1-D arrays of one length; names carry their unit, e.g. ``axial_stress_Pa``);
    ``summary``: the scalar results (also readable as attributes: ``result.peak_stress``);
    ``sim``: the :class:`~taichi_fdem.sim.simulation.Simulation` at the end of the test;
    ``bodies``: its bodies (specimen first); ``material``: the material(s) the specimen was
    built with (a copy of the one given, with the settings the test chose);
    ``settings``: what the test chose for a quasi-static run (damping, loading rate, time-step
    safety, joint penalty, platens), each one a keyword that overrides it;
    ``convergence``: with ``check=``, the relative change of the peak when the test is rerun
    at half the loading rate (``"rate"``) and/or half the mesh size (``"mesh"``).
    """

    test: str
    curve: dict
    summary: dict
    sim: object = None
    bodies: tuple = ()
    material: object = None
    notes: list = field(default_factory=list)
    settings: dict = field(default_factory=dict)
    convergence: dict = field(default_factory=dict)

    def __getattr__(self, name):
        summary = self.__dict__.get("summary", {})
        if name in summary:
            return summary[name]
        raise AttributeError(f"{type(self).__name__}({self.__dict__.get('test')!r}) has no {name!r}; "
                             f"its summary has {sorted(summary)}")

    @property
    def ae_events(self):
        """The acoustic-emission events of the run (``sim.cracks.ae_events()``), where the simulation has them."""
        if self.sim is None or not hasattr(self.sim, "ae_events"):
            raise AttributeError("this simulation has no ae_events()")
        return self.sim.cracks.ae_events()

    def to_csv(self, path: str) -> str:
        """Write the curve (one column per name, one row per sample) to ``path``; returns the path."""
        names = list(self.curve)
        cols = [np.asarray(self.curve[n]) for n in names]
        with open(path, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(names)
            for row in zip(*cols):
                w.writerow([f"{v:.8g}" for v in row])
        return path

    def __repr__(self):
        items = ", ".join(f"{k}={v:.4g}" for k, v in self.summary.items() if isinstance(v, float))
        return f"LabResult({self.test!r}, {items})"


def elastic_constants(strain, stress, lateral, plane: str = "strain", level: float = 0.5, band: float = 0.2):
    """(E [Pa], ν, E', ν') from a compression curve: the tangent at ``level`` × the peak.

    strain, stress, lateral: 1-D arrays (axial strain, axial stress [Pa], lateral strain;
    compression positive, expansion of the sides positive).  The tangent is the least-squares
    slope over the pre-peak samples with stress within ``level`` ± ``band`` of the peak; ν' is
    the slope of the lateral against the axial strain there.  The plane model measures the
    plane moduli: in plane strain E' = E/(1 − ν²) and ν' = ν/(1 − ν), so ν = ν'/(1 + ν'),
    E = E'(1 − ν²); in plane stress E = E', ν = ν'.
    """
    strain, stress, lateral = (np.asarray(a, dtype=np.float64) for a in (strain, stress, lateral))
    k = int(np.argmax(stress))
    peak = stress[k]
    sel = np.zeros(len(stress), bool)
    sel[: k + 1] = np.abs(stress[: k + 1] / peak - level) <= band
    if sel.sum() < 2:
        raise ValueError(f"lab: fewer than 2 samples within {level:.0%} ± {band:.0%} of the peak: "
                         "record more samples (samples=)")
    e_p = float(np.polyfit(strain[sel], stress[sel], 1)[0])
    nu_p = float(np.polyfit(strain[sel], lateral[sel], 1)[0])
    if plane == "strain":
        nu = nu_p / (1.0 + nu_p)
        return e_p * (1.0 - nu * nu), nu, e_p, nu_p
    if plane == "stress":
        return e_p, nu_p, e_p, nu_p
    raise ValueError(f"lab: plane must be 'strain' or 'stress', got {plane!r}")


def lab_materials(material, factor: float, where: str):
    """(the material(s) with the joint penalty of a lab specimen, the penalty [Pa] of the first,
    whether it was raised): a Material, or a dict of them, with ``joint_penalty`` = ``factor`` × E
    wherever the material leaves it unset (copies: the Materials given are not changed)."""
    from ..material import Material
    if not (isinstance(factor, (int, float)) and math.isfinite(factor) and factor > 0):
        raise ValueError(f"{where}: joint_penalty_factor must be a positive number (× E), got {factor!r}")

    def one(m):
        if m.joint_penalty is not None or not m.can_fracture:
            return m
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            return m.with_(joint_penalty=factor * m.young)
    if isinstance(material, dict):
        out = {k: one(m) for k, m in material.items()}
        first_in, first = next(iter(material.values())), next(iter(out.values()))
    elif isinstance(material, Material):
        out = first = one(material)
        first_in = material
    else:
        raise TypeError(f"{where}: material must be a Material or a dict of Materials, got {type(material).__name__}")
    pf = first.joint_penalty if first.joint_penalty is not None else 10.0 * first.young
    return out, float(pf), first_in.joint_penalty is None and first_in.can_fracture


def check_keyword(check, where: str):
    """The convergence reruns that ``check`` asks for: () for None, ("rate",), ("mesh",) or both."""
    if check not in CHECKS:
        raise ValueError(f"{where}: check must be None, 'rate', 'mesh' or 'both', got {check!r}")
    return {None: (), "rate": ("rate",), "mesh": ("mesh",), "both": ("rate", "mesh")}[check]


def convergence(result: LabResult, reruns: dict, key: str = "peak_stress") -> dict:
    """Relative change of ``result.summary[key]`` in each rerun ({name: LabResult}), signed:
    (rerun − result) / result."""
    base = result.summary[key]
    return {name: float((r.summary[key] - base) / base) for name, r in reruns.items()}


def check_rate(transits: float, where: str) -> None:
    """Refuse a loading that reaches the expected peak in fewer than ``MIN_TRANSITS`` P-wave transits."""
    if not (math.isfinite(transits) and transits >= MIN_TRANSITS):
        raise ValueError(f"{where}: the loading reaches the expected peak in {transits:g} P-wave transits of the "
                         f"specimen; a quasi-static test needs >= {MIN_TRANSITS:g} (60-100 recommended)")


def warn_kinetic(ratio: float, where: str, stacklevel: int = 3) -> None:
    """Warn (RuntimeWarning) when the specimen's kinetic/strain energy at half the peak exceeds ``MAX_KINETIC_RATIO``
    (``stacklevel``: of the warning, counted from this function: 3 points at the caller's caller)."""
    if ratio > MAX_KINETIC_RATIO:
        warnings.warn(f"{where}: kinetic / strain energy of the specimen at half the peak is {ratio:.3g} "
                      f"(> {MAX_KINETIC_RATIO}): the test is not quasi-static; load more slowly, or damp the specimen's "
                      "material (Material(damping=1.0): without damping its elastic waves ring and the peak is "
                      "not the material's)", RuntimeWarning,
                      stacklevel=stacklevel)


def specimen_kinetic(sim, body) -> float:
    """Kinetic energy [J per unit thickness] of one body's nodes."""
    m = sim.node_masses(body)
    v = sim.node_velocities(body)
    return float(0.5 * (m * (v * v).sum(axis=1)).sum())


@dataclass
class Envelope:
    """A fitted failure envelope (compression positive, Pa).

    Mohr–Coulomb: σ1 = σc + k σ3 with k = (1 + sin φ)/(1 − sin φ), c = σc (1 − sin φ)/(2 cos φ).
    Hoek–Brown (intact rock, s = 1, a = 0.5): σ1 = σ3 + σci √(m_i σ3/σci + 1).
    ``residual_mc``, ``residual_hb``: RMS misfits of σ1 [Pa].
    """

    cohesion: float
    friction_angle: float
    ucs_mc: float
    k: float
    m_i: float
    ucs_hb: float
    residual_mc: float
    residual_hb: float

    def sigma1_mc(self, sigma3):
        """σ1 [Pa] of the Mohr–Coulomb fit at σ3 [Pa]."""
        return self.ucs_mc + self.k * np.asarray(sigma3, dtype=np.float64)

    def sigma1_hb(self, sigma3):
        """σ1 [Pa] of the Hoek–Brown fit at σ3 [Pa]."""
        s3 = np.asarray(sigma3, dtype=np.float64)
        return s3 + self.ucs_hb * np.sqrt(self.m_i * s3 / self.ucs_hb + 1.0)


def fit_envelope(results=None, sigma3=None, sigma1=None) -> Envelope:
    """Fit Mohr–Coulomb (c, φ) and Hoek–Brown (m_i) envelopes to peak strengths.

    Either ``results`` (lab results with ``.confinement`` and ``.peak_stress``, e.g. of
    :func:`taichi_fdem.lab.triaxial` and :func:`taichi_fdem.lab.ucs`) or the arrays ``sigma3``,
    ``sigma1`` [Pa] (compression positive), at least two distinct confinements.

    Mohr–Coulomb: linear least squares of σ1 = σc + k σ3; φ = asin((k − 1)/(k + 1)),
    c = σc/(2√k).  Hoek–Brown (Hoek & Brown 1980; intact, s = 1, a = 0.5): least squares of
    (σ1 − σ3)² = σci² + m_i σci σ3, linear in σ3 (the fit Hoek & Brown recommend), so
    σci = √intercept, m_i = slope/σci.
    """
    if results is not None:
        sigma3 = [r.confinement for r in results]
        sigma1 = [r.peak_stress for r in results]
    s3 = np.asarray(sigma3, dtype=np.float64)
    s1 = np.asarray(sigma1, dtype=np.float64)
    if s3.shape != s1.shape or s3.ndim != 1 or len(np.unique(s3)) < 2:
        raise ValueError("fit_envelope: needs sigma3 and sigma1 of one length with >= 2 distinct confinements")
    if np.any(s3 < 0) or np.any(s1 <= s3):
        raise ValueError("fit_envelope: needs sigma3 >= 0 and sigma1 > sigma3 (compression positive, Pa)")
    k, ucs = np.polyfit(s3, s1, 1)
    if k <= 1:
        raise ValueError(f"fit_envelope: the strength does not rise with confinement (k = {k:.3g} <= 1)")
    phi = math.asin((k - 1) / (k + 1))
    c = ucs / (2 * math.sqrt(k))
    slope, icpt = np.polyfit(s3, (s1 - s3) ** 2, 1)
    if icpt <= 0:
        raise ValueError("fit_envelope: Hoek–Brown fit gives σci² <= 0; the points are not Hoek–Brown-like")
    sci = math.sqrt(icpt)
    env = Envelope(cohesion=float(c), friction_angle=math.degrees(phi), ucs_mc=float(ucs), k=float(k),
                   m_i=float(slope / sci), ucs_hb=sci, residual_mc=0.0, residual_hb=0.0)
    env.residual_mc = float(np.sqrt(np.mean((env.sigma1_mc(s3) - s1) ** 2)))
    env.residual_hb = float(np.sqrt(np.mean((env.sigma1_hb(s3) - s1) ** 2)))
    return env
