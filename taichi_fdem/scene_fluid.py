"""The fluid of a scene's fracture network: :meth:`FluidScene.set_fluid` and
:meth:`FluidScene.inject`, mixed into :class:`~taichi_fdem.scene.Scene` (docs/theory/fluid.md;
the network is built by :mod:`taichi_fdem.sim.fluid`, the kernels are :mod:`taichi_fdem.engine.fluid`)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Optional

from .material import Fluid, check_finite


@dataclass
class _FluidSpec:
    """The fluid of a scene (:meth:`Scene.set_fluid`)."""
    fluid: Fluid
    aperture_min: float
    aperture_max: Optional[float]
    initial_pressure: float
    conduct: str


@dataclass
class _Injection:
    """A source of the fracture network (:meth:`Scene.inject`): exactly one of rate, pressure."""
    where: Callable
    rate: Optional[float]
    pressure: Optional[float]
    curve: object = None


class FluidScene:
    """The fluid methods of :class:`~taichi_fdem.scene.Scene` (its ``_fluid`` and
    ``_injections``)."""

    _fluid: Optional[_FluidSpec] = None

    def set_fluid(self, fluid: Fluid, aperture_min: float, aperture_max: float | None = None,
                  initial_pressure: float = 0.0, conduct: str = "broken") -> None:
        """Fill the fracture network with a compressible fluid that flows by the cubic law and
        pushes on the fracture faces (hydro-mechanical coupling, :mod:`taichi_fdem.engine.fluid`).

        The network: every pre-existing crack edge (``add_body(cracks=)``) and every joint of a
        fracturing body (``add_body(fracture=)``, ``add_joint_set``) once it conducts.  Fluid
        is stored at the network's nodes, the original mesh vertices on those edges (one node
        where several edges meet), and flows along the edges, q = −w³/(12 μ) ∂p/∂s [m²/s per
        unit thickness].  The hydraulic aperture w is the mean normal opening of an edge's two
        faces, clamped to [aperture_min, aperture_max]; the pressure follows dp = K dV/V from
        the fluid's mass and the node's volume Σ L w / 2, and acts on both faces of every
        conducting edge as a follower pressure.  Edges that start to conduct take their fluid
        from their neighbours (mass is kept).  The network is closed: fluid leaves it only
        through pressure sources (no leak-off into the rock matrix, no outflow where a crack
        meets the body's surface).

        Parameters
        ----------
        fluid : :class:`~taichi_fdem.material.Fluid` (ρ, K, μ).
        aperture_min : residual hydraulic aperture a_min [m], > 0: the aperture of closed or
            compressed faces (it also sets the fluid's stiffness K/a_min per unit area in the
            stable time step).
        aperture_max : largest hydraulic aperture [m] (None: no bound), > aperture_min.
        initial_pressure : pressure [Pa], >= 0, of the fluid in the edges that conduct at the
            start (the crack edges, at the aperture of the rest mesh).
        conduct : which joints conduct: "broken" (default; a joint conducts once it has broken,
            docs/theory/joints.md §7.8) or "damaged" (also once it has softened past its peak
            strength: any stored damage D > 0 at one of its points, §7.5).

        A later call replaces the fluid; the sources (:meth:`inject`) stay.  The scene must
        have cracks or joints (checked at build).  Scenes with a fluid run the parallel
        strategy one step per launch (no team launch).
        """
        where = "Scene.set_fluid"
        if not isinstance(fluid, Fluid):
            raise TypeError(f"{where}: fluid must be a taichi_fdem.Fluid, got {type(fluid).__name__}")
        amin = check_finite("aperture_min", aperture_min, where)
        if amin <= 0:
            raise ValueError(f"{where}: aperture_min must be > 0 m, got {aperture_min}")
        amax = None
        if aperture_max is not None:
            amax = check_finite("aperture_max", aperture_max, where)
            if amax <= amin:
                raise ValueError(f"{where}: aperture_max must be > aperture_min = {amin:g} m, got {aperture_max}")
        p0 = check_finite("initial_pressure", initial_pressure, where)
        if p0 < 0:
            raise ValueError(f"{where}: initial_pressure must be >= 0 Pa, got {initial_pressure}")
        if conduct not in ("broken", "damaged"):
            raise ValueError(f"{where}: conduct must be 'broken' or 'damaged', got {conduct!r}")
        self._fluid = _FluidSpec(fluid, amin, amax, p0, conduct)

    def inject(self, where: Callable, rate: float | None = None, pressure: float | None = None,
               curve: Curve | None = None) -> None:
        """A source of the fracture network on the network nodes selected by ``where(x, y)``
        (their initial coordinates [m]): a crack's centre, a notch, a borehole wall.

        Give exactly one of ``rate``, a volume rate [m²/s per unit thickness], >= 0, into the
        network, shared equally among the selected nodes that conduct (nothing enters while
        none does), or ``pressure``, a pressure [Pa], >= 0, prescribed on the selected nodes
        that conduct (the fluid it adds or takes out, as a source or a drain, is its rate).
        ``curve`` is a :class:`Curve` multiplying the rate or the pressure.

        Several calls make several sources, reported in order by ``sim.fluid.injection_rates()``
        (positive into the network); ``sim.fluid.injection_pressure()`` is the pressure at the first.
        Needs :meth:`set_fluid` first.  A predicate that selects no network node is an error at
        build.
        """
        what = "Scene.inject"
        if self._fluid is None:
            raise ValueError(f"{what}: the scene has no fluid; call scene.set_fluid(...) first")
        if not callable(where):
            raise TypeError(f"{what}: where must be a callable where(x, y) -> bool array (initial coordinates)")
        if (rate is None) == (pressure is None):
            raise ValueError(f"{what}: give exactly one of rate [m²/s] or pressure [Pa], got "
                             f"rate={rate!r}, pressure={pressure!r}")
        if rate is not None:
            rate = check_finite("rate", rate, what)
            if rate < 0:
                raise ValueError(f"{what}: rate must be >= 0 m²/s (a drain is a pressure source), got {rate}")
        if pressure is not None:
            pressure = check_finite("pressure", pressure, what)
            if pressure < 0:
                raise ValueError(f"{what}: pressure must be >= 0 Pa, got {pressure}")
        self._injections.append(_Injection(where, rate, pressure, self._check_curve(curve, what)))
