"""The contact step limit uses only the material pairs that can touch (docs/theory/elements.md §6.2)."""
import numpy as np

import taichi_fdem as fdem

ROCK = fdem.Material(density=2600.0, young=20e9, poisson=0.2, name="rock")


def _platens(steel, prescribed=True):
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(0.05, 0.1, 0.0125), ROCK, name="specimen")
    pm = fdem.mesh.rectangle(0.08, 0.01, 0.005)
    kw = dict(prescribed_velocity=(0.0, 0.0)) if prescribed else {}
    scene.add_body(pm, steel, position=(0.0, 0.0555), name="top", **kw)
    scene.add_body(pm, steel, position=(0.0, -0.0555), name="bottom", **kw)
    return scene.build()


def test_stiff_platens_do_not_set_the_contact_step():
    steel = fdem.Material(density=7850.0, young=200e9, poisson=0.3, name="steel")     # p = 2e12 Pa
    soft = steel.with_(penalty=ROCK.contact_penalty)                                  # p = rock's
    a, b = _platens(steel), _platens(soft)
    # rock–steel couples take the rock's penalty: the stiff steel penalty changes nothing
    assert np.isclose(a.model.dt_contact, b.model.dt_contact, rtol=1e-12)
    # h √(ρ_min/p) with the rock's penalty and the smallest contact altitude
    alt = 0.0125 / np.sqrt(2.0)
    assert a.model.dt_contact <= alt * np.sqrt(2600.0 / ROCK.contact_penalty) * (1 + 1e-9)
    # free platens could meet each other: then steel–steel counts
    free = _platens(steel, prescribed=False)
    assert free.model.dt_contact < 0.5 * a.model.dt_contact
