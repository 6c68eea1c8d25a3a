"""The data model (taichi_fdem/engine/arrays.py) is the one description of the arrays: every array
a Model, State or Scratch holds is declared and allocated with its declared element type and
shape; the argpack groups, the checkpoint list, the counters and the documentation's table are
generated from the declarations, so an array declared in one place is allocated, grouped,
checkpointed and documented."""
from __future__ import annotations

import json
import os
import pathlib

import numpy as np
import pytest
import taichi as ti
from taichi.lang.matrix import MatrixNdarray, VectorNdarray

import taichi_fdem as fdem
from taichi_fdem import backend
from taichi_fdem.engine import arrays as decl
from taichi_fdem.engine import groups
from taichi_fdem.sim import arrays as sim_arrays
from taichi_fdem.sim.state import scratch_sizes, state_sizes

ROOT = pathlib.Path(__file__).resolve().parent.parent
ROCK = dict(density=2700.0, young=1e9, poisson=0.25)


def _rich(**build):
    """Fracture, contact with friction, a load, a prescribed body, damping and initial stress."""
    rock = fdem.Material(**ROCK, friction=0.5, tensile_strength=5e6, cohesion=1e7, fracture_energy=50.0,
                         damping=0.05)
    scene = fdem.Scene(gravity=(0.0, -9.81))
    top = scene.add_body(fdem.mesh.rectangle(0.2, 0.1, 0.03), rock, position=(0.0, 0.2), fracture=True)
    scene.add_body(fdem.mesh.rectangle(0.5, 0.1, 0.05), rock, position=(0.0, 0.0), fixed=True)
    scene.apply_pressure(lambda x, y: y > 0.24, 1e5, body=top)
    scene.initial_stress(-1e5, -2e5, body=top)
    return scene.build(**build)


def _plain():
    scene = fdem.Scene(gravity=(0.0, -9.81))
    scene.add_body(fdem.mesh.disk(radius=0.05, h=0.03), fdem.Material(**ROCK))
    return scene.build()


def _fluid():
    rock = fdem.Material(**ROCK, tensile_strength=3e5, cohesion=9e5, fracture_energy=1.0)
    scene = fdem.Scene(gravity=(0.0, 0.0))
    scene.add_body(fdem.mesh.rectangle(0.2, 0.2, 0.05), rock, fracture=True,
                   cracks=lambda x, y: (np.abs(y) < 1e-9) & (np.abs(x) < 0.06))
    scene.set_fluid(fdem.Fluid(bulk_modulus=1e8), aperture_min=1e-5)
    scene.inject(lambda x, y: (np.abs(x) < 1e-9) & (np.abs(y) < 1e-9), rate=1e-3)
    return scene.build(strategy="serial")


def _expect(spec, sizes):
    """(shape, element shape, Taichi dtype) a declaration gives at ``sizes``."""
    base = decl.element(spec.dtype)[0]
    dtype = {"real": backend.real_ti(), "i32": ti.i32}[base]
    return sim_arrays.shape_of(spec, sizes), sim_arrays.element_shape(spec, sizes), dtype


def _actual(arr):
    if isinstance(arr, MatrixNdarray):
        elem = (arr.n, arr.m)
    elif isinstance(arr, VectorNdarray):
        elem = (arr.n,)
    else:
        elem = ()
    return tuple(arr.shape), elem, arr.dtype


def _check(obj, role, sizes):
    held = {k for k, v in vars(obj).items() if isinstance(v, ti.Ndarray)}
    table = decl.declared(role)
    assert held == set(table), (f"{type(obj).__name__}: undeclared {sorted(held - set(table))}, "
                                f"not allocated {sorted(set(table) - held)}")
    for name, spec in table.items():
        assert _actual(getattr(obj, name)) == _expect(spec, sizes), (name, spec.dtype, spec.shape)


def _check_sim(sim):
    md, st, sw = sim.model, sim.state, sim.solver.scratch
    _check(md, decl.MODEL, md.sizes)
    _check(st, decl.STATE, state_sizes(md, st))
    _check(sw, decl.SCRATCH, scratch_sizes(md, st, sw))
    host = {k for k, v in vars(md).items() if isinstance(v, np.ndarray)}
    assert host == set(decl.declared(decl.HOST)), sorted(host ^ set(decl.declared(decl.HOST)))
    sim_arrays.check_host(md, md.sizes)


@pytest.mark.parametrize("make", [_plain, _rich, _fluid], ids=["plain", "rich", "fluid"])
def test_every_array_held_is_declared_and_allocated_as_declared(make):
    sim = make()
    _check_sim(sim)
    sim.step(3)
    _check_sim(sim)
    if make is _rich:
        assert sim.model.joint_prestress and sim.model.sizes["prestress"] and sim.model.damping
        assert sim.model.joint_prop.n == 14


def test_the_couple_buffer_and_the_assembly_are_reallocated_as_declared():
    sim = _rich(strategy="parallel")
    _check_sim(sim)                                       # block assembly
    sim._alloc_couples(3 * sim.state.couple_max)          # a couple buffer that grew
    _check_sim(sim)
    sim.solver.assembly = "slots"
    _check_sim(sim)
    sim.step(2)
    _check_sim(sim)


def test_an_excavation_reallocates_as_declared():
    sim = _plain()                                        # no prescribed velocity: one-row node_free
    assert sim.model.node_free.shape == (1,)
    sim.step(2)
    assert sim.remove(where=lambda x, y: x ** 2 + y ** 2 < 0.02 ** 2) > 0
    assert sim.model.sizes["bc"] and sim.model.node_free.shape == (sim.model.node_count,)
    assert sim.state.counters.switches & groups.SWITCH_BC              # the kernels apply the constraints now
    _check_sim(sim)
    sim.step(2)
    _check_sim(sim)


def test_groups_are_the_declarations_of_each_group():
    for group, (_, names) in groups.GROUPS.items():
        assert names == tuple(a.name for a in decl.ARRAYS if a.group == group)
    assert tuple(groups.GROUPS) == decl.GROUP_ORDER
    in_groups = [n for _, names in groups.GROUPS.values() for n in names]
    assert sorted(in_groups) == sorted(a.name for a in decl.ARRAYS if a.role != decl.HOST)
    assert all(a.group == "" for a in decl.ARRAYS if a.role == decl.HOST)
    assert set(groups.TEAM_MEMBERS) <= set(in_groups) and set(groups.SERIAL_FLUID_MEMBERS) <= set(in_groups)


def test_counter_constants_and_names_follow_the_slot_declarations():
    k = 0
    for s in decl.REAL_SLOTS:
        assert getattr(groups, s.name) == k
        k += s.count
    assert k == groups.REAL_COUNTERS == decl.REAL_COUNTERS
    k = 0
    for s in decl.INT_SLOTS:
        assert getattr(groups, s.name) == k
        k += s.count
    assert k == groups.INT_COUNTERS
    assert groups.RANGE == groups.SPLIT + groups.MAX_FORCE_BLOCKS + 1
    with pytest.raises(ValueError, match="do not match the declared slots"):
        decl.slot_numbers(decl.REAL_SLOTS, "TIME")


def test_counters_read_and_write_the_slots():
    sim = _rich()
    sim.step(5)
    c, st = sim.state.counters, sim.state
    assert c.time == pytest.approx(5 * sim.dt) and c.time == st.step_real[groups.TIME]
    assert c.couples == st.step_int[groups.COUPLES] and isinstance(c.couples, int)
    assert c.nb_pairs == sim.model.nb_count
    assert list(c.split) == list(st.step_int.to_numpy()[groups.SPLIT:groups.RANGE])
    c.work_load = 2.5
    assert st.step_real[groups.WORK_LOAD] == 2.5
    with pytest.raises(AttributeError):
        c.no_such_counter = 1
    assert "couples=" in repr(c)


def test_checkpoints_save_exactly_the_declared_state_arrays(tmp_path):
    sim = _rich()
    sim.step(3)
    path = tmp_path / "a.ckpt"
    sim.save(path)
    with np.load(path) as z:
        saved = [k[3:] for k in z.files if k.startswith("nd.")]
        meta = json.loads(str(z["meta"]))
    assert sorted(saved) == sorted(decl.declared(decl.STATE))
    assert list(meta["ndarrays"]) == list(decl.declared(decl.STATE))


def test_an_undeclared_array_is_refused():
    sim = _plain()
    sim.state.node_extra = ti.ndarray(ti.f64, shape=3)
    with pytest.raises(TypeError, match=r"not declared \['node_extra'\]"):
        sim.state.ndarrays()
    with pytest.raises(TypeError, match="not declared"):
        sim.save(os.devnull)


def test_a_declaration_is_enough_to_allocate_group_checkpoint_and_document_an_array(monkeypatch, tmp_path):
    """A newcomer's array, declared in one place (engine.arrays.ARRAYS), is allocated at its
    declared shape by the build, is a member of its group, is saved and restored by checkpoints
    and appears in the documentation's table.  (The argpack types of engine.groups are made at
    import: the kernels take a new member once the package is imported with it.)"""
    extra = decl.Array("tri_extra", "tris", decl.STATE, "real vec2", ("E",), "m", "an array added by a newcomer")
    monkeypatch.setattr(decl, "ARRAYS", decl.ARRAYS + (extra,))
    assert decl.members("tris")[-1] == "tri_extra"
    assert "tri_extra" in decl.declared(decl.STATE)
    assert "| `tri_extra` | state | `real vec2` | `(E,)` | m | an array added by a newcomer |" in sim_arrays.markdown()
    sim = _plain()
    assert sim.state.tri_extra.shape == (sim.model.tri_count,) and sim.state.tri_extra.n == 2
    sim.step(2)
    sim.state.tri_extra.from_numpy(np.full((sim.model.tri_count, 2), 7.0, backend.real_np()))
    sim.save(tmp_path / "x.ckpt")
    back = fdem.Simulation.load(tmp_path / "x.ckpt")
    assert np.all(back.state.tri_extra.to_numpy() == 7.0)


def test_the_declarations_are_consistent():
    names = [a.name for a in decl.ARRAYS]
    assert len(names) == len(set(names))
    for a in decl.ARRAYS:
        assert decl.symbols(a) <= set(decl.SIZES), a.name
        assert a.name.split("_")[0] in ("node", "load", "curve", "tri", "mat", "couple", "contact", "body", "det",
                                        "asm", "joint", "step", "fluid", "heat", "bc", "nb"), a.name
    used = set().union(*(decl.symbols(a) for a in decl.ARRAYS))
    assert used == set(decl.SIZES), sorted(set(decl.SIZES) - used)


def test_the_docs_table_is_the_generated_one():
    page = ROOT / "docs" / "reference" / "arrays.md"
    assert page.read_text(encoding="utf-8") == sim_arrays.markdown(), \
        "docs/reference/arrays.md is out of date: run python docs/_ext/array_table.py"
    for a in decl.ARRAYS:
        assert f"| `{a.name}` |" in page.read_text(encoding="utf-8")


def _kernel_leaves(kernel) -> int:
    """Argument leaves of a launch of ``kernel``, counted from its signature: one per scalar, one
    per argpack plus one per member, none for a template."""
    import inspect
    packs = {id(t): m for t, m in groups.GROUPS.values()}
    packs[id(groups.SerialFluidGroup)] = groups.SERIAL_FLUID_MEMBERS
    packs[id(groups.TeamGroup)] = groups.TEAM_MEMBERS
    n = 0
    for p in inspect.signature(kernel).parameters.values():
        t = p.annotation
        if id(t) in packs:
            n += 1 + len(packs[id(t)])
        elif not isinstance(t, type(ti.template())):
            n += 1
    return n


def test_every_step_kernel_keeps_free_argument_leaves():
    """Each step kernel keeps at least 3 of Taichi's 64 argument leaves free: room for the arrays
    of new physics (engine.groups.LEAVES_FREE)."""
    from taichi_fdem.engine import step
    kernels = {"serial": step.run_steps_serial, "serial_fluid": step.run_steps_serial_fluid,
               "parallel": step.step_parallel, "parallel_fluid": step.step_parallel_fluid,
               "team": step.run_steps_blocks}
    assert groups.LEAVES_FREE >= 3
    for name, kernel in kernels.items():
        assert _kernel_leaves(kernel) == groups.LEAVES[name], name
        assert 64 - groups.LEAVES[name] >= groups.LEAVES_FREE, (name, groups.LEAVES[name])
