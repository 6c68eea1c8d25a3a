"""Materials: bulk elastic properties, bedding (transverse isotropy), viscous damping, thermal and
contact properties (SI units)."""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace

import numpy as np

from . import elasticity


def check_finite(name: str, value, where: str) -> float:
    """``float(value)``, or TypeError (not a number) / ValueError (NaN, inf) naming it and where."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise TypeError(f"{where}: {name} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"{where}: {name} must be finite, got {value!r}")
    return v


#: Sanity bounds of the material parameters (SI).  Beyond them products such as E·ρ (the
#: viscous damping constant) or p·h² overflow a float64, or the value is a typo by many orders
#: of magnitude: the stiffest solids have E ~ 1e12 Pa, the densest ρ ~ 2.3e4 kg/m³.
BOUNDS = {
    "density": (1e-6, 1e6, "kg/m³"),
    "young": (1e-6, 1e16, "Pa"),
    "penalty": (1e-6, 1e18, "Pa"),
    "tangential_penalty": (1e-6, 1e18, "Pa"),
    "joint_penalty": (1e-6, 1e18, "Pa"),
    "tensile_strength": (1e-6, 1e16, "Pa"),
    "cohesion": (1e-6, 1e16, "Pa"),
    "fracture_energy": (1e-12, 1e12, "J/m²"),
    "fracture_energy_shear": (1e-12, 1e12, "J/m²"),
    "friction": (0.0, 1e6, ""),
}


#: The range of real solids (SI): outside it a value is most likely in the wrong unit
#: (``young=20`` meant 20 GPa, ``density=2.6`` meant 2.6 g/cm³).  Soft foams and gels have
#: E ~ 1e4–1e6 Pa, diamond 1.2e12 Pa; cork ~120 kg/m³, osmium 2.26e4 kg/m³.
#: ``Material`` warns (RuntimeWarning) outside these; it does not refuse.
REAL_RANGE = {
    "density": (50.0, 2.5e4, "kg/m³", "e.g. 2600 for granite, not 2.6 g/cm³"),
    "young": (1e3, 1.5e12, "Pa", "e.g. 20e9 for 20 GPa"),
    "tensile_strength": (1.0, 1e10, "Pa", "e.g. 8e6 for 8 MPa"),
}

#: Joint cohesion over tensile strength below which ``Material`` warns.  Intact rock has
#: UCS/BTS ≈ 10–20 (Sheorey 1997, *Empirical Rock Failure Criteria*; Hoek 2007, *Practical Rock
#: Engineering* §11); with Mohr–Coulomb UCS = 2c cos φ/(1 − sin φ) and φ = 30–40° that is
#: c ≈ 2–4 f_t.  With c ≤ f_t a compressed joint fails in shear before the tensile strength is
#: reached: a Brazilian disc with c = f_t, φ = 30° fails by shear in its centre, at about
#: 0.56 f_t, instead of splitting at f_t (with c = 3 f_t, φ = 35° it splits: docs/guide/fracture.md).
COHESION_WARN_RATIO = 1.0


def _check_positive(name: str, value, where: str, unit: str) -> float:
    """``float(value)`` after :func:`check_finite`; ValueError unless > 0."""
    v = check_finite(name, value, where)
    if v <= 0:
        raise ValueError(f"{where}: {name} must be > 0 {unit}, got {value!r}")
    return v


@dataclass(frozen=True)
class Bedding:
    """The bedding of a transversely isotropic (TI) material (docs/theory/anisotropy.md,
    docs/guide/anisotropy.md): the plane of isotropy is the bedding plane, which contains the
    out-of-plane axis.  ``Material.young`` and ``Material.poisson`` are E1 and ν1 in the bedding
    plane; the bedding adds the constants across it.

    Parameters
    ----------
    angle : float or callable
        Dip of the bedding from the x axis [degrees], counter-clockwise; or a callable
        ``f(x, y) -> degrees`` (NumPy-vectorised over arrays of the rest coordinates [m]),
        evaluated at each triangle's centroid at build (a folded layer).
    young_normal : float
        E2 [Pa], > 0: Young's modulus across the bedding.
    poisson_normal : float
        ν21 (Amadei's convention): the strain in the bedding plane per strain across it, under a
        stress across it, so the compliance term is S₁₂ = −ν21/E2; the other ratio is
        ν12 = ν21·E1/E2 (reciprocity ν12/E1 = ν21/E2).
    shear_modulus : float
        G2 [Pa], > 0: the shear modulus of planes normal to the bedding.

    Other Parameters
    ----------------
    tensile_strength, cohesion, fracture_energy, fracture_energy_shear : float or None
        Strength of joints parallel to the bedding: f_t [Pa], c [Pa], G_I [J/m²], G_II [J/m²],
        each > 0 (None: the Material's value).
    friction_angle : float or None
        φ_i of joints parallel to the bedding [degrees], in [0, 90) (None: the Material's value).
    expansion_normal : float or None
        Linear thermal expansion across the bedding α2 [1/K] (None: ``Material.expansion``).
    spacing : float or None
        Distance [m] between weak bedding planes, > 0 (None: no bedding planes).

    The five elastic constants must be positive definite (Lempriere 1968): E1, E2, G2 > 0,
    −1 < ν1 < 1 and 1 − ν1 − 2 ν21² E1/E2 > 0; :class:`Material` refuses a set that violates
    one, naming the bound.
    """

    angle: object
    young_normal: float
    poisson_normal: float
    shear_modulus: float
    tensile_strength: float | None = None
    cohesion: float | None = None
    friction_angle: float | None = None
    fracture_energy: float | None = None
    fracture_energy_shear: float | None = None
    expansion_normal: float | None = None
    spacing: float | None = None

    def __post_init__(self):
        where = "Bedding"
        if not callable(self.angle):
            object.__setattr__(self, "angle", check_finite("angle", self.angle, where))
        object.__setattr__(self, "young_normal", _check_positive("young_normal", self.young_normal, where, "Pa"))
        object.__setattr__(self, "poisson_normal", check_finite("poisson_normal", self.poisson_normal, where))
        object.__setattr__(self, "shear_modulus", _check_positive("shear_modulus", self.shear_modulus, where, "Pa"))
        for key, unit in (("tensile_strength", "Pa"), ("cohesion", "Pa"), ("fracture_energy", "J/m²"),
                          ("fracture_energy_shear", "J/m²"), ("spacing", "m")):
            v = getattr(self, key)
            if v is not None:
                object.__setattr__(self, key, _check_positive(key, v, where, unit))
        if self.friction_angle is not None:
            object.__setattr__(self, "friction_angle", check_finite("friction_angle", self.friction_angle, where))
            if not 0.0 <= self.friction_angle < 90.0:
                raise ValueError(f"{where}: friction_angle must be in [0, 90) degrees, got {self.friction_angle}")
        if self.expansion_normal is not None:
            object.__setattr__(self, "expansion_normal",
                               check_finite("expansion_normal", self.expansion_normal, where))
        for key in ("young_normal", "shear_modulus", "tensile_strength", "cohesion", "fracture_energy",
                    "fracture_energy_shear"):
            lo, hi, unit = BOUNDS["young" if key in ("young_normal", "shear_modulus") else key]
            v = getattr(self, key)
            if v is not None and not lo <= v <= hi:
                raise ValueError(f"{where}: {key}={v:g} {unit} is outside the accepted range [{lo:g}, {hi:g}] "
                                 f"{unit} (SI units; a typo?)")

    def angles(self, x, y) -> np.ndarray:
        """The bedding angle [degrees] at the points (x, y) [m]: the constant ``angle``, or the
        callable's values (ValueError when it does not return one finite number per point)."""
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        if not callable(self.angle):
            return np.full(x.shape, self.angle)
        try:
            a = np.asarray(self.angle(x.copy(), y.copy()), dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"Bedding: angle(x, y) must return the angles [degrees] as numbers: {exc}") from exc
        if a.shape == ():
            a = np.full(x.shape, float(a))
        if a.shape != x.shape:
            raise ValueError(f"Bedding: angle(x, y) must return one angle per point (shape {x.shape}), got shape "
                             f"{a.shape}; write it with NumPy operations on the arrays x and y")
        if not np.all(np.isfinite(a)):
            raise ValueError("Bedding: angle(x, y) returned a non-finite angle")
        return a

    def with_(self, **changes) -> "Bedding":
        """A copy with some parameters changed (validated again)."""
        return replace(self, **changes)


@dataclass(frozen=True)
class Material:
    """A bulk material of the deformable triangles and its contact properties (SI units).

    Parameters
    ----------
    density : float
        Mass density ρ [kg/m³], > 0.
    young : float
        Young's modulus E [Pa], > 0 (with ``bedding``: E1 in the bedding plane).
    poisson : float
        Poisson's ratio ν, −1 < ν < 0.5 (with ``bedding``: ν1 in the bedding plane, −1 < ν1 < 1
        and the bounds of :class:`Bedding`).
    friction : float
        Coulomb friction coefficient μ_f ≥ 0 of contacts (docs/theory/contact.md §5.1).  The
        coefficient of a couple of two materials is the smaller of the two unless
        :meth:`Scene.set_interaction <taichi_fdem.scene.Scene.set_interaction>` says otherwise.
    damping : float
        Viscous damping β in [0, 1], as a fraction of critical damping of the highest
        element mode: k_s = 2 h β √(E ρ) (docs/theory/elements.md §3.4; with ``bedding``, E the
        larger of E1 and E2).  0 (default) for wave and impact problems, 0.1–1 for quasi-static runs.
    penalty : float or None
        Normal contact penalty p [Pa].  Default ``10 · young``: by the book's estimate
        (p. 79–80) the penetration is then about 1/10 of the element's own elastic
        deformation, and the contact time-step limit h√(ρ/p) is ~3× below the elastic one.
        Raise it (50–100 E) where contact stiffness matters (Hertz contact).
    tangential_penalty : float or None
        Tangential (stick) stiffness k_t of friction [Pa = N/m per metre of thickness per
        metre of slip].  Default: equal to ``penalty``.
    contact_damping : float
        Normal contact damping ratio ξ in [0, 1] (docs/theory/contact.md §5.2),
        c_n = 4 ξ √(p ρ).  Default 0 (elastic contact).
    name : str
        Free label.

    Other Parameters
    ----------------
    tensile_strength : float or None
        Fracture (cohesive joints between triangles, docs/theory/joints.md §7; used by bodies
        added with ``fracture=True``): tensile strength f_t [Pa], > 0.
    cohesion : float or None
        c [Pa] of the Mohr–Coulomb shear strength (default: f_t, with a RuntimeWarning).
        Rock has c ≈ 2–4 f_t (UCS/BTS ≈ 10–20); with c ≤ f_t compressed joints fail in shear
        first, and a Brazilian test returns about half of f_t (see ``COHESION_WARN_RATIO``).
        ``Material`` warns when c ≤ f_t (given, or by default).
    friction_angle : float
        Internal friction angle φ_i of the joints [degrees] (default 30).
    fracture_energy : float or None
        G_I, mode I fracture energy [J/m²], > 0.
    fracture_energy_shear : float or None
        G_II, mode II fracture energy [J/m²] (default: 5 × G_I).
    joint_penalty : float or None
        p_f [Pa] (default ``10 · young``).  Intact joints add compliance L/p_f next to the
        element's h/E, so the effective modulus is about E/(1 + E/p_f): ~9 % softer at the
        default; a warning is given below 10·E.
    bedding : Bedding or None
        Transversely isotropic elasticity with the plane of isotropy along the bedding
        (docs/theory/anisotropy.md); None (default): isotropic.
    conductivity : float or None
        Thermal conductivity k [W/(m·K)], > 0 (heat conduction; None: none).
    heat_capacity : float or None
        Specific heat capacity c [J/(kg·K)], > 0 (heat conduction; None: none).
    expansion : float
        Linear thermal expansion coefficient α [1/K] (with ``bedding``: α1 in the bedding plane;
        ``Bedding.expansion_normal`` gives α2 across it).  Default 0.
    """

    density: float = 2700.0
    young: float = 30e9
    poisson: float = 0.25
    friction: float = 0.0
    damping: float = 0.0
    penalty: float | None = None
    tangential_penalty: float | None = None
    contact_damping: float = 0.0
    name: str = ""
    tensile_strength: float | None = None
    cohesion: float | None = None
    friction_angle: float = 30.0
    fracture_energy: float | None = None
    fracture_energy_shear: float | None = None
    joint_penalty: float | None = None
    bedding: Bedding | None = None
    conductivity: float | None = None
    heat_capacity: float | None = None
    expansion: float = 0.0

    def __post_init__(self):
        where = f"Material{'(' + repr(self.name) + ')' if self.name else ''}"
        for key in ("density", "young", "poisson", "friction", "damping", "contact_damping"):
            object.__setattr__(self, key, check_finite(key, getattr(self, key), where))
        for key in ("penalty", "tangential_penalty", "tensile_strength", "cohesion", "fracture_energy",
                    "fracture_energy_shear", "joint_penalty"):
            v = getattr(self, key)
            if v is not None:
                object.__setattr__(self, key, check_finite(key, v, where))
                if getattr(self, key) <= 0:
                    raise ValueError(f"{where}: {key} must be > 0, got {v}")
        object.__setattr__(self, "friction_angle", check_finite("friction_angle", self.friction_angle, where))
        if not 0.0 <= self.friction_angle < 90.0:
            raise ValueError(f"{where}: friction_angle must be in [0, 90) degrees, got {self.friction_angle}")
        if self.density <= 0:
            raise ValueError(f"{where}: density must be > 0 kg/m³, got {self.density}")
        if self.young <= 0:
            raise ValueError(f"{where}: young (Young's modulus) must be > 0 Pa, got {self.young}")
        if self.bedding is None and not -1.0 < self.poisson < 0.5:
            raise ValueError(f"{where}: poisson must satisfy -1 < ν < 0.5, got {self.poisson}")
        if self.friction < 0:
            raise ValueError(f"{where}: friction coefficient must be >= 0, got {self.friction}")
        if not 0.0 <= self.damping <= 1.0:
            raise ValueError(f"{where}: damping (fraction of critical, β) must be in [0, 1], got {self.damping}")
        if not 0.0 <= self.contact_damping <= 1.0:
            raise ValueError(f"{where}: contact_damping (ξ) must be in [0, 1], got {self.contact_damping}")
        if self.penalty is not None and self.penalty <= 0:
            raise ValueError(f"{where}: penalty must be > 0 Pa, got {self.penalty}")
        if self.tangential_penalty is not None and self.tangential_penalty <= 0:
            raise ValueError(f"{where}: tangential_penalty must be > 0 Pa, got {self.tangential_penalty}")
        for key, (lo, hi, unit) in BOUNDS.items():
            v = getattr(self, key)
            if v is not None and v != 0.0 and not lo <= v <= hi:
                raise ValueError(f"{where}: {key}={v:g}{' ' + unit if unit else ''} is outside the accepted range "
                                 f"[{lo:g}, {hi:g}]{' ' + unit if unit else ''} (SI units; a typo?)")
        for key, (lo, hi, unit, hint) in REAL_RANGE.items():
            v = getattr(self, key)
            if v is not None and not lo <= v <= hi:
                warnings.warn(f"{where}: {key}={v:g} {unit} is outside the range of real materials "
                              f"[{lo:g}, {hi:g}] {unit}; the unit is {unit} ({hint})", RuntimeWarning, stacklevel=3)
        if self.tensile_strength is not None and self.fracture_energy is not None:
            c = self.cohesion if self.cohesion is not None else self.tensile_strength
            if c <= COHESION_WARN_RATIO * self.tensile_strength:
                warnings.warn(f"{where}: joint cohesion c = {c:g} Pa{' (the default f_t)' if self.cohesion is None else ''}"
                              f" is <= tensile_strength f_t = {self.tensile_strength:g} Pa: compressed joints fail "
                              "in shear first (a Brazilian disc fails at ~0.56 f_t); rock has c ≈ 2–4 f_t "
                              "(UCS/BTS ≈ 10–20): pass cohesion= explicitly", RuntimeWarning, stacklevel=3)
        self._check_thermal_and_bedding(where)

    def _check_thermal_and_bedding(self, where: str) -> None:
        """The heat fields (conductivity, heat_capacity > 0 when given; expansion finite) and the
        bedding (a :class:`Bedding`, its five constants positive definite with young and poisson)."""
        for key, unit in (("conductivity", "W/(m·K)"), ("heat_capacity", "J/(kg·K)")):
            v = getattr(self, key)
            if v is not None:
                object.__setattr__(self, key, _check_positive(key, v, where, unit))
        object.__setattr__(self, "expansion", check_finite("expansion", self.expansion, where))
        if self.bedding is None:
            return
        if not isinstance(self.bedding, Bedding):
            raise TypeError(f"{where}: bedding must be a taichi_fdem.Bedding or None, got {self.bedding!r}")
        E1 = check_finite("young", self.young, where)
        nu1 = check_finite("poisson", self.poisson, where)
        b = self.bedding
        elasticity.check_ti(E1, nu1, b.young_normal, b.poisson_normal, b.shear_modulus, where)

    # --- derived quantities -------------------------------------------------------------------
    @property
    def anisotropic(self) -> bool:
        """True with a :class:`Bedding` (transversely isotropic elasticity)."""
        return self.bedding is not None

    @property
    def ti_constants(self) -> tuple:
        """(E1 [Pa], ν1, E2 [Pa], ν21, G2 [Pa]) (docs/theory/anisotropy.md); an isotropic material:
        (E, ν, E, ν, E/(2(1 + ν)))."""
        if self.bedding is None:
            return elasticity.isotropic_constants(self.young, self.poisson)
        b = self.bedding
        return self.young, self.poisson, b.young_normal, b.poisson_normal, b.shear_modulus

    def stiffness_2d(self, plane: str) -> tuple:
        """(C11, C22, C12, C66) [Pa] of the plane problem in the bedding frame
        (:func:`taichi_fdem.elasticity.stiffness_2d`; isotropic: the isotropic stiffness)."""
        return elasticity.stiffness_2d(*self.ti_constants, plane)

    @property
    def out_of_plane_ratios(self) -> tuple:
        """(k₁, k₂) of the plane-strain out-of-plane stress σ_zz = k₁ σ₁ + k₂ σ₂ (σ₁, σ₂ along and
        across the bedding): (ν1, ν21 E1/E2); isotropic (ν, ν)."""
        if self.bedding is None:
            return self.poisson, self.poisson
        return self.poisson, self.bedding.poisson_normal * self.young / self.bedding.young_normal

    def thermal_expansion_2d(self, plane: str) -> tuple:
        """(α1*, α2*) [1/K], the effective expansion of the plane problem in the bedding frame
        (:func:`taichi_fdem.elasticity.thermal_strain_2d`; isotropic plane strain: α(1 + ν))."""
        a2 = self.expansion
        if self.bedding is not None and self.bedding.expansion_normal is not None:
            a2 = self.bedding.expansion_normal
        return elasticity.thermal_strain_2d(*self.ti_constants, self.expansion, a2, plane)

    @property
    def contact_penalty(self) -> float:
        """Normal contact penalty p [Pa] (``penalty`` or the default 10·E)."""
        return self.penalty if self.penalty is not None else 10.0 * self.young

    @property
    def contact_tangential_penalty(self) -> float:
        """Tangential friction stiffness k_t [Pa] (``tangential_penalty`` or p)."""
        return self.tangential_penalty if self.tangential_penalty is not None else self.contact_penalty

    @property
    def shear_modulus(self) -> float:
        """μ = E / (2(1+ν)) [Pa] (with ``bedding``: the shear modulus of the bedding plane)."""
        return self.young / (2.0 * (1.0 + self.poisson))

    def lambda_y(self, plane: str) -> float:
        """λ_Y of the finite-strain law T = (μ/J)(B−I) + λ_Y (J − 1/J) I [Pa].

        Because J − 1/J ≈ 2 tr ε, λ_Y is *half* the usual Lamé λ of the plane problem, so that
        small strains reproduce Hooke's law with this E and ν (docs/theory/elements.md §3.2, the factor-2 caveat).
        With ``bedding`` (whose triangles use the stiffness of :meth:`stiffness_2d`), half of its C12.
        """
        if self.bedding is not None:
            return 0.5 * self.stiffness_2d(plane)[2]
        E, nu = self.young, self.poisson
        if plane == "stress":
            return E * nu / (2.0 * (1.0 - nu * nu))
        if plane == "strain":
            return E * nu / (2.0 * (1.0 + nu) * (1.0 - 2.0 * nu))
        raise ValueError(f"plane must be 'strain' or 'stress', got {plane!r}")

    def p_wave_speed(self, plane: str) -> float:
        """Dilatational wave speed c_p [m/s] of the plane problem (docs/theory/elements.md §6.2); with
        ``bedding``, the speed √(M/ρ) of the stiffest direction (M:
        :func:`taichi_fdem.elasticity.p_wave_modulus`, docs/theory/anisotropy.md)."""
        if self.bedding is not None:
            return math.sqrt(elasticity.p_wave_modulus(*self.stiffness_2d(plane)) / self.density)
        E, nu, rho = self.young, self.poisson, self.density
        if plane == "stress":
            return math.sqrt(E / (rho * (1.0 - nu * nu)))
        return math.sqrt(E * (1.0 - nu) / (rho * (1.0 + nu) * (1.0 - 2.0 * nu)))

    @property
    def can_fracture(self) -> bool:
        """True when the fracture parameters (tensile_strength, fracture_energy) are set."""
        return self.tensile_strength is not None and self.fracture_energy is not None

    def joint_properties(self) -> tuple:
        """(f_t [Pa], c [Pa], tan φ_i, G_I [J/m²], G_II [J/m²], p_f [Pa]) of the joints."""
        if not self.can_fracture:
            raise ValueError(f"Material{'(' + repr(self.name) + ')' if self.name else ''}: a fracturing body "
                             "needs tensile_strength [Pa] and fracture_energy [J/m²]")
        ft = self.tensile_strength
        c = self.cohesion if self.cohesion is not None else ft
        gi = self.fracture_energy
        gii = self.fracture_energy_shear if self.fracture_energy_shear is not None else 5.0 * gi
        pf = self.joint_penalty if self.joint_penalty is not None else 10.0 * self.young
        return ft, c, math.tan(math.radians(self.friction_angle)), gi, gii, pf

    def with_(self, **changes) -> "Material":
        """A copy with some parameters changed (validated again)."""
        return replace(self, **changes)


#: The range of real fracturing fluids (SI): outside it a value is most likely in the wrong
#: unit.  Water: ρ = 1000 kg/m³, K = 2.2e9 Pa, μ = 1e-3 Pa·s; gases and foams are lighter and
#: far more compressible, drilling muds and gels denser and up to ~1e3 Pa·s viscous.
#: ``Fluid`` warns (RuntimeWarning) outside these; it does not refuse.
FLUID_RANGE = {
    "density": (1.0, 3000.0, "kg/m³", "e.g. 1000 for water, not 1 g/cm³"),
    "bulk_modulus": (1e5, 1e10, "Pa", "e.g. 2.2e9 for water"),
    "viscosity": (1e-6, 1e4, "Pa·s", "e.g. 1e-3 for water, not 1 cP"),
}


@dataclass(frozen=True)
class Fluid:
    """A compressible Newtonian fluid in the fracture network (``scene.set_fluid``).

    Parameters
    ----------
    density : float
        Reference density ρ [kg/m³], > 0: the fluid's mass is its volume at this density (the
        network stores that volume, ``M/ρ``).
    bulk_modulus : float
        K [Pa], > 0: dp = K dV/V (linearised about the reference density).
    viscosity : float
        Dynamic viscosity μ [Pa·s], > 0: the cubic law q = −w³/(12 μ) ∂p/∂s.
    name : str, optional
        Free label.

    Values outside :data:`FLUID_RANGE` give a RuntimeWarning (a unit slip, most likely).
    """

    density: float = 1000.0
    bulk_modulus: float = 2.2e9
    viscosity: float = 1e-3
    name: str = ""

    def __post_init__(self):
        where = f"Fluid{'(' + repr(self.name) + ')' if self.name else ''}"
        for key in ("density", "bulk_modulus", "viscosity"):
            v = check_finite(key, getattr(self, key), where)
            if v <= 0:
                raise ValueError(f"{where}: {key} must be > 0 {FLUID_RANGE[key][2]}, got {getattr(self, key)}")
            object.__setattr__(self, key, v)
        for key, (lo, hi, unit, hint) in FLUID_RANGE.items():
            v = getattr(self, key)
            if not lo <= v <= hi:
                warnings.warn(f"{where}: {key}={v:g} {unit} is outside the range of real fluids "
                              f"[{lo:g}, {hi:g}] {unit}; the unit is {unit} ({hint})", RuntimeWarning, stacklevel=3)

    @property
    def diffusivity_factor(self) -> float:
        """K/(12 μ) [1/s]: the pressure diffusivity of a channel of aperture w is w² K/(12 μ) [m²/s]."""
        return self.bulk_modulus / (12.0 * self.viscosity)

    def with_(self, **changes) -> "Fluid":
        """A copy with some parameters changed (validated again)."""
        return replace(self, **changes)
