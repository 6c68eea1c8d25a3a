"""The package's layers (docs/architecture.md): imports run downwards only, modules stay small,
kernels take a handful of parameters."""
from __future__ import annotations

import ast
import pathlib

import pytest

PKG = pathlib.Path(__file__).resolve().parent.parent / "taichi_fdem"

# lower number = lower layer; a module may import its own layer or any lower one
LAYERS = [
    ("backend", "material", "elasticity", "mesh", "discontinuity"),
    ("engine",),
    ("timestep", "arrays", "views", "selection", "fluid", "heat", "topology", "model", "state", "motion"),
    ("guards", "energies", "cracks", "ae", "results", "recorders", "outputs", "settings", "profiling", "excavation", "team",
     "solver",
     "simulation"),
    ("records", "scene"),
    ("render", "io", "cli", "sweep", "verification", "lab", "__init__"),
]


def _layer(module: str) -> int:
    parts = module.split(".")
    head = parts[1] if parts[0] == "sim" and len(parts) > 1 else parts[0]
    if module == "sim":                     # the simulation layer's package itself
        head = "simulation"
    for k, names in enumerate(LAYERS):
        if head in names:
            return k
    raise AssertionError(f"module {module!r} is in no layer of tests/test_architecture.py")


def _modules():
    for path in sorted(PKG.rglob("*.py")):
        rel = path.relative_to(PKG).with_suffix("")
        yield ".".join(rel.parts), path


def _imports(name: str, path: pathlib.Path):
    """taichi_fdem modules imported anywhere in the file (function-level imports included)."""
    tree = ast.parse(path.read_text())
    pkg_parts = name.split(".")[:-1] if not name.endswith("__init__") else name.split(".")[:-1]
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg_parts[: len(pkg_parts) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
                if not target:                      # "from . import x"
                    for alias in node.names:
                        yield alias.name, node.lineno
                    continue
                if node.module is None:
                    for alias in node.names:
                        yield target + "." + alias.name, node.lineno
                    continue
                yield target, node.lineno
            elif node.module and node.module.startswith("taichi_fdem"):
                rest = node.module[len("taichi_fdem"):].lstrip(".")
                if rest:
                    yield rest, node.lineno
                else:
                    for alias in node.names:
                        yield alias.name, node.lineno
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("taichi_fdem."):
                    yield alias.name[len("taichi_fdem."):], node.lineno


def test_imports_run_downwards():
    bad = []
    for name, path in _modules():
        own = _layer(name)
        for target, line in _imports(name, path):
            if target.split(".")[0] in ("__version__",):
                continue
            if _layer(target) > own:
                bad.append(f"{name}:{line} imports {target} (layer {_layer(target)} > {own})")
    assert not bad, "upward imports:\n" + "\n".join(bad)


#: the longest a function (``def`` line and decorators to its last line) may be
MAX_FUNCTION_LINES = 80


def _function_lengths() -> dict:
    """{module.function: lines} of every function and method of the package (a method under its
    own name: ``module.name``)."""
    out = {}
    for name, path in _modules():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                start = min([node.lineno] + [d.lineno for d in node.decorator_list])
                key = f"{name}.{node.name}"
                out[key] = max(out.get(key, 0), node.end_lineno - start + 1)
    return out


def test_no_function_over_80_lines():
    """Every function of the package, kernels and ``@ti.func`` included, is at most
    MAX_FUNCTION_LINES long (split by concept: a phase, a law, a stage)."""
    lengths = _function_lengths()
    assert lengths["engine.joints.eval_joint"] <= MAX_FUNCTION_LINES      # (the walk sees the @ti.func functions)
    over = {k: n for k, n in lengths.items() if n > MAX_FUNCTION_LINES}
    assert not over, "functions over %d lines: %s" % (MAX_FUNCTION_LINES, sorted(over.items(), key=lambda kv: -kv[1]))


def test_kernels_take_a_handful_of_parameters():
    counts = {}
    for name, path in _modules():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef) and any(
                    ast.unparse(d).endswith("kernel") for d in node.decorator_list):
                counts[f"{name}.{node.name}"] = len(node.args.args)
    assert counts, "no kernels found"
    worst = max(counts, key=counts.get)
    assert counts[worst] <= 12, (worst, counts[worst])


def test_serial_kernel_fits_taichi_argument_budget():
    from taichi_fdem.engine import groups
    # Taichi 1.7 refuses a launch with more than 64 argument leaves (argpack members included)
    assert groups.LEAVES_SERIAL <= 64
    # the team launch takes one argpack of every member it uses (detection included)
    assert groups.LEAVES_PARALLEL <= 64 and groups.LEAVES_TEAM <= 64
    assert set(groups.TEAM_MEMBERS) <= {n for _, members in groups.GROUPS.values() for n in members}
    names = [n for _, members in groups.GROUPS.values() for n in members]
    assert len(names) == len(set(names)), "argpack members must be unique across groups"


@pytest.mark.parametrize("module", ["taichi_fdem.sim.simulation", "taichi_fdem.engine.step", "taichi_fdem.sim.model"])
def test_core_does_not_load_drivers(module):
    """Importing the core loads no renderer, sweep, scene-file or checkpoint module."""
    import subprocess
    import sys
    code = (f"import sys, importlib; importlib.import_module({module!r}); "
            "loaded = [m for m in sys.modules if m.startswith(('taichi_fdem.render', 'taichi_fdem.sweep', "
            "'taichi_fdem.io', 'taichi_fdem.cli'))]; print(loaded); assert not loaded")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr


def _import_graph() -> dict:
    """module -> the package modules it imports (function-level imports included; an imported
    name resolves to the module that defines it, a package to its __init__)."""
    mods = dict(_modules())

    def resolve(target):
        while target:
            if target in mods:
                return target
            if target + ".__init__" in mods:
                return target + ".__init__"
            target = target.rpartition(".")[0]
        return None

    return {name: {r for t, _ in _imports(name, path) if (r := resolve(t)) is not None and r != name}
            for name, path in mods.items()}


def _find_cycle(graph: dict):
    """The first circle a depth-first search of ``graph`` meets, as a list of nodes, or None."""
    colour, path = {}, []

    def visit(v):
        colour[v] = 1
        path.append(v)
        for w in sorted(graph.get(v, ())):
            if colour.get(w) == 1:
                return path[path.index(w):] + [w]
            if w not in colour and (found := visit(w)):
                return found
        path.pop()
        colour[v] = 2
        return None

    for v in sorted(graph):
        if v not in colour and (found := visit(v)):
            return found
    return None


def test_no_import_cycle():
    """The import graph of the package (every module, function-level imports included) is
    acyclic, so no two modules of a layer or subpackage import each other, directly or around
    a circle."""
    graph = _import_graph()
    assert "mesh.arrangement" in graph["mesh.generators"]          # (the graph sees the imports)
    cycle = _find_cycle(graph)
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_cycle_search_finds_circles():
    assert _find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _find_cycle({"a": {"b", "c"}, "b": {"c"}, "c": set()}) is None
    assert _find_cycle({"x": {"y"}, "y": {"y2"}, "y2": {"y"}}) == ["y", "y2", "y"]


#: the one ``__getattr__`` allowed: the deprecated names of version 0.1.0 (sim.settings.MOVED)
DEPRECATION_ONLY = {"sim/settings.py": {"ModelValues.__getattr__"}}


@pytest.mark.parametrize("where", ["sim/simulation.py", "sim/results.py", "sim/settings.py", "sim/model.py", "sim/state.py",
                                   "sim/views.py", "sim/cracks.py", "sim/fluid.py", "sim/solver.py"])
def test_no_attribute_forwarding(where):
    """No class of the simulation layer forwards unknown attributes (``__getattr__`` or
    ``__getattribute__``): Simulation, its views, Model and State answer only the names they
    declare, apart from the table of deprecated names (tested below).  (A module-level PEP 562
    loader, as in taichi_fdem/__init__.py, is not a class's.)"""
    tree = ast.parse((PKG / where).read_text())
    bad = [f"{cls.name}.{fn.name}" for cls in ast.walk(tree) if isinstance(cls, ast.ClassDef)
           for fn in cls.body if isinstance(fn, ast.FunctionDef) and fn.name in ("__getattr__", "__getattribute__")]
    bad = [b for b in bad if b not in DEPRECATION_ONLY.get(where, ())]
    assert not bad, f"{where}: attribute forwarding in {bad}"


def test_simulation_model_state_classes_do_not_forward():
    from taichi_fdem.sim.model import Model, State
    from taichi_fdem.sim.settings import ModelValues
    from taichi_fdem.sim.simulation import Simulation
    for cls in (Simulation, Model, State):
        for klass in cls.__mro__[:-1]:
            assert "__getattr__" not in vars(klass) or klass is ModelValues, f"{klass.__name__} defines __getattr__"


def test_the_deprecated_names_are_the_only_ones_answered():
    import warnings
    import taichi_fdem as fdem
    from taichi_fdem.sim.settings import MOVED
    scene = fdem.Scene()
    scene.add_body(fdem.mesh.disk(0.05, 0.02), fdem.Material(density=1000.0, young=1e6, poisson=0.2))
    sim = scene.build()
    for name in ("no_such_name", "model_values", "node_x", "crack_event"):
        with pytest.raises(AttributeError):
            getattr(sim, name)
    public = [n for n in dir(sim) if not n.startswith("_")]
    assert len(public) <= 33 and not set(public) & set(MOVED), public      # (33: temperatures, heat_flow of issue 48)
    for name, (where, new) in MOVED.items():
        with pytest.warns(DeprecationWarning, match=f"sim.{where}.{new}"):
            value = getattr(sim, name)
        assert value == getattr(getattr(sim, where), new) or callable(value)


# ---- no Taichi internals ------------------------------------------------------------------------
# Names outside Taichi's public API: private modules and attributes (a leading underscore under
# ``ti.`` / ``taichi.``), the front end's modules, and the internals of a kernel object.
TAICHI_PRIVATE = [
    r"\b(?:ti|taichi)(?:\.[A-Za-z]\w*)*\._(?!_)\w",          # taichi._lib, ti.lang._ndarray (not __version__)
    r"\bfrom\s+taichi(?:\.\w+)*\s+import\s+(?:\(?\s*)?(?:[\w\s,]*,\s*)?_(?!_)\w",   # from taichi.lang import _ndarray
    r"\bkernel_impl\b", r"\bast_transformer", r"\b_lib\b", r"\b_ti_core\b", r"\.func\.func\b",
    r"\._primal\b", r"\bcompiled_kernels\b", r"\blaunch_kernel\b", r"\bensure_compiled\b",
    r"\b(?:ti|taichi)\.lang\.impl\b", r"\bfrom\s+taichi\.lang\s+import\s+(?:[\w\s,]*,\s*)?impl\b",
]


def taichi_private_names(paths) -> list[str]:
    """``file:line: text`` of every line of ``paths`` that names a Taichi internal
    (:data:`TAICHI_PRIVATE`)."""
    import re
    pattern = re.compile("|".join(TAICHI_PRIVATE))
    hits = []
    for path in paths:
        for no, line in enumerate(pathlib.Path(path).read_text().splitlines(), 1):
            if pattern.search(line):
                hits.append(f"{path}:{no}: {line.strip()}")
    return hits


def test_no_taichi_private_names_in_the_package():
    """The package uses Taichi's public API only (no patched or private Taichi names), which is
    what lets pyproject.toml ask for a Taichi floor (``taichi>=1.7.0``) without a ceiling."""
    hits = taichi_private_names(sorted(PKG.rglob("*.py")))
    assert not hits, "Taichi internals used:\n" + "\n".join(hits)


def test_taichi_private_names_are_caught(tmp_path):
    planted = tmp_path / "planted.py"
    planted.write_text("import taichi as ti\nfrom taichi._lib import utils\nfrom taichi.lang import kernel_impl\n"
                       "x = ti.lang._ndarray.Ndarray\nprim = kernel._primal\nsrc = f.func.func\n"
                       "from taichi.lang import impl\nfrom taichi.lang import _ndarray\n"
                       "y = ti.Vector([1.0, 2.0])\nimport taichi_fdem._x\nv = ti.__version__\n")
    hits = taichi_private_names([planted])
    assert [int(h.split(":")[1]) for h in hits] == [2, 3, 4, 5, 6, 7, 8], hits


def test_the_architecture_page_names_every_module():
    """docs/architecture.md describes the code file by file: every module of the package is
    named there (as ``file.py`` within its folder's section, or with its folder)."""
    text = (PKG.parent / "docs" / "architecture.md").read_text()
    missing = [name for name, path in _modules()
               if path.name != "__init__.py" and f"`{path.name}`" not in text and f"{path.name}" not in text]
    assert not missing, "modules docs/architecture.md does not name: " + ", ".join(missing)
