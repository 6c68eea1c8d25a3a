"""Standard rock-mechanics lab tests as functions (``fdem.lab``).

::

    import taichi_fdem as fdem
    rock = fdem.Material(density=2600, young=20e9, poisson=0.2, tensile_strength=8e6,
                         fracture_energy=30, cohesion=24e6, friction_angle=35)
    r = fdem.lab.brazilian(rock, diameter=0.05, h=0.0025)
    print(r.peak_stress, r.summary); r.to_csv("bts.csv")
    u = fdem.lab.ucs(rock, 0.05, 0.1, 0.005)            # .peak_stress .young .poisson .curve
    env = fdem.lab.fit_envelope([u] + [fdem.lab.triaxial(rock, 0.05, 0.1, 0.005, s3) for s3 in (2e6, 5e6)])

Each test returns a :class:`LabResult` (``.curve`` columns, ``.summary`` scalars readable as
attributes, ``.to_csv(path)``, ``.sim``); ``video=path`` writes a video coloured by joint
damage.  Each test chooses what a quasi-static run needs (local damping, loading rate,
time-step safety, joint penalty, platens) and reports it in ``.settings``; ``check="rate"``,
``"mesh"`` or ``"both"`` reruns it at half the rate and/or mesh size and reports the change of
the peak in ``.convergence``.  Quasi-static loading is checked two ways: a loading that reaches the expected peak in
fewer than ``MIN_TRANSITS`` P-wave transits of the specimen is refused, and the specimen's
kinetic/strain energy ratio at half the peak is reported (``kinetic_ratio``) and warns above
``MAX_KINETIC_RATIO``.
"""
from .tensile import brazilian
from .compressive import compression, triaxial, ucs
from .results import COMPRESSION_JOINT_PENALTY_FACTOR, JOINT_PENALTY_FACTOR, MAX_KINETIC_RATIO, MIN_TRANSITS, Envelope, LabResult, elastic_constants, fit_envelope
from .shear import direct_shear

__all__ = ["ucs", "triaxial", "compression", "brazilian", "direct_shear", "fit_envelope", "Envelope", "LabResult",
           "elastic_constants", "MIN_TRANSITS", "MAX_KINETIC_RATIO", "JOINT_PENALTY_FACTOR",
           "COMPRESSION_JOINT_PENALTY_FACTOR"]
