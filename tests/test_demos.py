"""The demos run (short mode, in-process), pass their physics checks and write a video."""
import importlib.util
import os
import sys

DEMOS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "demos")


def _load(name):
    if DEMOS not in sys.path:
        sys.path.insert(0, DEMOS)          # the demos import their helper module _common
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


def test_two_disks_short(tmp_path):
    r = _run("two_disks", tmp_path)
    assert r["momentum_rel_error"] < 1e-10
    assert r["exchange_error_A"] < 0.05 and r["exchange_error_B"] < 0.05
    assert r["energy_rel_error"] < 0.01


def test_pile_short(tmp_path):
    r = _run("pile", tmp_path)
    assert r["max_excursion_m"] < 0.005              # 1 % of the 0.5 m box
    assert r["energy_rise_max_frac_pe0"] < 0.03
    assert r["potential_released_J"] > 0            # the bodies fell
