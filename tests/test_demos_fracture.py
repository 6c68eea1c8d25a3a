"""The fracture demos run (short mode, in-process), pass their checks and write a video."""
import importlib.util
import os
import sys

DEMOS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "demos")


def _load(name):
    if DEMOS not in sys.path:
        sys.path.insert(0, DEMOS)
    spec = importlib.util.spec_from_file_location(f"demo_{name}", os.path.join(DEMOS, f"{name}.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _run(name, tmp_path):
    out = tmp_path / "x.mp4"
    result = _load(name).main(["--short", "--out", str(out)])
    assert result["passed"] is True
    assert out.is_file() and out.stat().st_size > 0
    import imageio.v3 as iio
    assert sum(1 for _ in iio.imiter(str(out))) >= 2
    return result


def test_brazilian_short(tmp_path):
    r = _run("brazilian", tmp_path)
    assert abs(r["sigma_t_over_ft"] - 1.0) < 0.2
    assert r["central_fraction"] >= 0.8
    assert os.path.isfile(r["csv"])


def test_fragment_plate_short(tmp_path):
    r = _run("fragment_plate", tmp_path)
    assert r["broken_joints"] >= 5 and r["fragments"] >= 2
    assert r["energy_rel_error_max"] < 0.02
