"""Every demo runs (short mode, in-process), passes its physics checks and writes a video."""
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


def _run(name, tmp_path, still=False):
    out = tmp_path / "x.mp4"
    argv = ["--short", "--out", str(out)]
    if still:
        argv += ["--still", str(tmp_path / "still.png")]
    result = _load(name).main(argv)
    assert result["passed"] is True
    assert out.is_file() and out.stat().st_size > 0
    import imageio.v3 as iio
    assert sum(1 for _ in iio.imiter(str(out))) >= 2
    if still:
        assert (tmp_path / "still.png").is_file()
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


def test_tower_short(tmp_path):
    r = _run("tower", tmp_path, still=True)
    assert r["max_block_speed_before_mps"] < 0.1          # 1 % of the projectile speed
    assert r["momentum_balance_rel_error"] < 0.05         # momentum change = floor impulse
    assert r["momentum_x_kept"] > 0.8
    assert r["energy_rise_max_frac"] < 0.02
    assert r["upper_disp_mean_m"] > 0.05                  # half a block height


def test_incline_short(tmp_path):
    r = _run("incline", tmp_path, still=True)
    assert r["rel_error"] < 0.02
    assert r["distance_sim_m"] > 0.0


def test_brazilian_short(tmp_path):
    r = _run("brazilian", tmp_path)
    assert abs(r["sigma_t_over_ft"] - 1.0) < 0.2
    assert r["central_fraction"] >= 0.8
    assert os.path.isfile(r["csv"])


def test_fragment_plate_short(tmp_path):
    r = _run("fragment_plate", tmp_path)
    assert r["broken_joints"] >= 5 and r["fragments"] >= 2
    assert r["energy_rel_error_max"] < 0.02
