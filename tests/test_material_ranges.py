"""Material warns on values outside the range of real materials and on a joint cohesion c <= f_t."""
import warnings

import pytest

import taichi_fdem as fdem


def test_unit_mistakes_warn_naming_value_and_unit():
    with pytest.warns(RuntimeWarning) as rec:
        fdem.Material(young=20, density=2.6)
    text = " ".join(str(w.message) for w in rec)
    assert "young=20 Pa" in text and "density=2.6 kg/m³" in text


def test_cohesion_at_or_below_ft_warns_and_rock_values_do_not():
    with pytest.warns(RuntimeWarning, match="cohesion"):
        fdem.Material(young=20e9, density=2600.0, tensile_strength=8e6, fracture_energy=30.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fdem.Material(young=20e9, density=2600.0, tensile_strength=8e6, fracture_energy=30.0, cohesion=24e6,
                      friction_angle=35.0)
