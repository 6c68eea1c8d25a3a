"""benchmarks/results.md and the README's performance table are what benchmarks/report.py
generates from benchmarks/results.json, and report.py reads the outputs of the benchmarks."""
from __future__ import annotations

import csv
import json
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "benchmarks"))
import report  # noqa: E402


def _data():
    with open(os.path.join(ROOT, "benchmarks", "results.json")) as fh:
        return json.load(fh)


def test_results_md_is_generated_from_results_json(tmp_path):
    out = tmp_path / "results.md"
    text = report.write_markdown(_data(), str(out))
    with open(os.path.join(ROOT, "benchmarks", "results.md"), encoding="utf-8") as fh:
        assert fh.read() == text


def test_the_readme_table_is_the_generated_one():
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as fh:
        assert report.readme_table(_data()) in fh.read()


def test_report_reads_the_pile_csv_and_the_fracture_json(tmp_path):
    pile = tmp_path / "pile.csv"
    with open(pile, "w", newline="") as fh:
        wr = csv.DictWriter(fh, fieldnames=["triangles", "couples", "strategy", "threads", "steps_per_s",
                                            "steps_per_s_best", "cold_s", "warm_s", "nodes"])
        wr.writeheader()
        wr.writerow(dict(triangles=1000, couples=600, strategy="serial", threads=1, steps_per_s=2000.0,
                         steps_per_s_best=2100.0, cold_s=3.0, warm_s=1.0, nodes=800))
        wr.writerow(dict(triangles=1000, couples=600, strategy="parallel", threads=2, steps_per_s=3000.0,
                         steps_per_s_best=3100.0, cold_s=5.0, warm_s=2.0, nodes=800))
    frac = tmp_path / "fracture.json"
    frac.write_text(json.dumps([{"triangles": 600, "threads": 1, "strategy": "serial", "rate_first_window": 4.0,
                                 "rate_all": 3.5, "rate_min_chunk": 2.0, "broken": 7, "energy_error_end": 1e-4,
                                 "chunks": []}]))
    js = tmp_path / "results.json"
    js.write_text(json.dumps(_data()))
    md = tmp_path / "results.md"
    assert report.main(["--pile", str(pile), "--fracture", str(frac), "--json", str(js), "--out", str(md),
                        "--host", "test host", "--date", "today"]) == 0
    new = json.loads(js.read_text())
    assert new["startup"]["parallel"] == {"cold_s": 5.0, "warm_s": 2.0} and new["host"] == "test host"
    text = md.read_text()
    # 2,000 steps/s of 1,000 triangles = 2.0 M triangle-steps/s
    assert "| 1,000 | 600 | 2,000 (2.0 M) [2,100] | 3,000 (3.0 M) [3,100] |" in text
    assert "| 600 | 1 | serial | 4.00 M | 3.50 M | 2.00 M | 7 | 1.0e-04 |" in text


def test_report_reads_the_calibration_json(tmp_path):
    cal = tmp_path / "calibration.json"
    cal.write_text(json.dumps([{"problem": "bts", "method": "bracket", "budget": 12, "evaluations": 4, "to_2pc": 4,
                                "to_5pc": 3, "best_error": {"tensile_strength": -0.001}, "converged": True},
                               {"problem": "bts", "method": "de", "budget": 12, "evaluations": 10, "to_2pc": None,
                                "to_5pc": None, "best_error": {"tensile_strength": 0.09}, "converged": False}]))
    js = tmp_path / "results.json"
    js.write_text(json.dumps(_data()))
    md = tmp_path / "results.md"
    assert report.main(["--calibration", str(cal), "--json", str(js), "--out", str(md)]) == 0
    assert json.loads(js.read_text())["calibration"][0]["method"] == "bracket"
    text = md.read_text()
    assert "| bts | bracket | 12 | 4 | 4 | 3 | tensile_strength -0.10 % |" in text
    assert "| bts | de | 12 | 10 | — | — | tensile_strength +9.00 % |" in text
