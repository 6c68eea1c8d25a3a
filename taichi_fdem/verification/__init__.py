"""Verification cases with analytic references (docs/verification.md §8).

Each ``case_NAME(resolution=..., safety=0.2, penalty_factor=10.0, precision="f64", **kw)`` builds
its scene, runs it and returns a dict with at least

* ``error``: the relative error against the analytic value (the largest of the checked
  quantities when several are checked),
* ``wall``: wall-clock seconds spent stepping (inside ``Simulation.step``), ``wall_total``:
  with the measuring (sampling, force evaluations) added; build excluded,
* ``build``: wall seconds of ``Scene.build``, ``steps``: time steps taken, ``dt`` [s],
* the measured and analytic values themselves.

``resolution`` is the case's mesh-size knob (documented per case), ``safety`` the time-step
fraction of the stable limit, ``penalty_factor`` the contact penalty in units of E (cases
without contact ignore it), ``precision`` "f64" or "f32": Taichi must already be initialised
with that precision (``fdem.init(precision=...)`` resets Taichi, so a sweep over precisions
runs each in its own process; ``benchmarks/accuracy.py`` does).

Modules: :mod:`.cases` (wave, two bars, Hertz, cantilever, rotation, incline, disks) and
:mod:`.fracture` (joint pull, direct tension, Brazilian disc, fragmenting plate) and :mod:`.rock`
(loads and rock mechanics, docs/theory/loads.md §12.6: Kirsch, Lamé, uniaxial compression, triaxial
strength), sharing :mod:`._common`; :mod:`.hydro` holds the analytic references of fluid-driven
fracture (docs/theory/hydro.md §14.2: Sneddon's pressurised crack, KGD in its toughness- and
viscosity-dominated limits) and :mod:`.hydro_cases` the cases that run them with the fluid engine
(``case_sneddon``, ``case_kgd``; not in ``CASES``: they need the fluid and take tens of seconds).
"""
from ._common import E, NU, RHO, _build, _centroid_velocity, _crossing, _precision, _result  # noqa: F401
from .cases import (cantilever_deflection, case_cantilever, case_disks, case_hertz, case_incline,  # noqa: F401
                    case_rotation, case_two_bars, case_wave, two_disks_scene)
from .fracture import (BRAZILIAN_MATERIAL, JointPair, brazilian_load, brazilian_result, brazilian_scene,  # noqa: F401
                       case_brazilian, case_direct_tension, case_joint_pull, fragment_plate_scene, hondros_factor)
from .rock import (TRIAXIAL_MATERIAL, axial_record, case_kirsch, case_lame, case_triaxial,  # noqa: F401
                   case_uniaxial, jointed_specimen_mesh, kirsch_hoop, lame, mohr_coulomb_peak, platen_scene,
                   triaxial_test)
from .hydro import (KGDSolution, kgd_dimensionless_toughness, kgd_toughness, kgd_viscosity,  # noqa: F401
                    plane_modulus, pressurised_crack_stress_intensity, sneddon_opening, sneddon_volume)
from .hydro_cases import case_kgd, case_sneddon, crack_plate_mesh, joint_fracture_energy, kgd_scene  # noqa: F401

CASES = {"wave": case_wave, "two_bars": case_two_bars, "hertz": case_hertz, "cantilever": case_cantilever,
         "rotation": case_rotation, "incline": case_incline, "disks": case_disks,
         "joint_pull": case_joint_pull, "direct_tension": case_direct_tension,
         "brazilian": case_brazilian, "kirsch": case_kirsch, "lame": case_lame, "uniaxial": case_uniaxial,
         "triaxial": case_triaxial}
