"""Write benchmarks/results.md, the latest benchmark figures, from benchmarks/results.json.

    python benchmarks/report.py                                   # results.json -> results.md
    python benchmarks/report.py --pile out/pile.csv --fracture out/fracture.json --host "..." --date 2026-12-04
    python benchmarks/report.py --readme                           # also print the README's table
    python benchmarks/report.py --lab out/lab.json                 # the lab tables of benchmarks/lab_defaults.py

``--pile`` takes the CSV of ``benchmarks/pile.py --csv``, ``--fracture`` the JSON of
``benchmarks/fracture.py --json``, ``--calibration`` that of ``benchmarks/calibration.py
--json`` and ``--lab`` that of ``benchmarks/lab_defaults.py --json``; their rows replace those
of results.json, which is written
back, and results.md is generated from it.  results.md is generated: edit results.json (or
re-run the benchmarks), not results.md.
"""
from __future__ import annotations

import argparse
import csv
import json
import os

HERE = os.path.dirname(os.path.abspath(__file__))
JSON_PATH = os.path.join(HERE, "results.json")
MD_PATH = os.path.join(HERE, "results.md")


def _num(v, fmt="{:,.0f}"):
    return "n/a" if v is None else fmt.format(v)


def pile_rows_from_csv(path: str) -> list[dict]:
    """The rows of ``pile.py --csv`` that results.json keeps."""
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    keep = []
    for r in rows:
        keep.append({"triangles": int(r["triangles"]), "couples": int(float(r["couples"])),
                     "strategy": r["strategy"], "threads": int(r["threads"]),
                     "steps_per_s": float(r["steps_per_s"]), "steps_per_s_best": float(r["steps_per_s_best"])})
        if r.get("cold_s") and r.get("warm_s"):
            keep[-1]["cold_s"], keep[-1]["warm_s"] = float(r["cold_s"]), float(r["warm_s"])
    return keep


def plate_rows_from_json(path: str) -> list[dict]:
    """The rows of ``fracture.py --json`` that results.json keeps [M triangle-steps/s]."""
    with open(path) as fh:
        res = json.load(fh)
    keys = ("triangles", "threads", "strategy", "rate_first_window", "rate_all", "rate_min_chunk", "broken",
            "energy_error_end")
    return [{k: r.get(k) for k in keys} for r in res]


def pile_table(rows: list[dict]) -> str:
    """Markdown: steps/s (M triangle-steps/s) [best window] per size, strategy and threads."""
    cols = sorted({(r["strategy"], r["threads"]) for r in rows}, key=lambda c: (c[0] != "serial", c[1]))
    sizes = sorted({r["triangles"] for r in rows})
    by = {(r["triangles"], r["strategy"], r["threads"]): r for r in rows}
    head = "| triangles | couples | " + " | ".join(f"{s}, {t} thread{'s' if t > 1 else ''}" for s, t in cols) + " |"
    out = [head, "|---:|---:|" + "---:|" * len(cols)]
    for n in sizes:
        cells = []
        for s, t in cols:
            r = by.get((n, s, t))
            cells.append("" if r is None else f"{r['steps_per_s']:,.0f} ({n * r['steps_per_s'] / 1e6:.1f} M) "
                                              f"[{r['steps_per_s_best']:,.0f}]")
        couples = next(r["couples"] for r in rows if r["triangles"] == n)
        out.append(f"| {n:,} | {couples:,} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def plate_table(rows: list[dict]) -> str:
    """Markdown: M triangle-steps/s of the plate impact per size and threads."""
    out = ["| triangles | threads | strategy | first 6,000 steps | whole run | slowest chunk | broken joints | ΔE/E0 at the end |",
           "|---:|---:|:--|---:|---:|---:|---:|---:|"]
    for r in sorted(rows, key=lambda r: (r["triangles"], r["threads"])):
        out.append(f"| {r['triangles']:,} | {r['threads']} | {r['strategy']} | {_num(r['rate_first_window'], '{:.2f} M')} | "
                   f"{_num(r['rate_all'], '{:.2f} M')} | {_num(r['rate_min_chunk'], '{:.2f} M')} | "
                   f"{_num(r['broken'])} | {_num(r['energy_error_end'], '{:.1e}')} |")
    return "\n".join(out)


def readme_table(data: dict) -> str:
    """The README's one performance table: serial on 1 thread against parallel on 2."""
    pile = {(r["triangles"], r["strategy"], r["threads"]): r for r in data["pile"]}
    out = ["| scene | triangles | serial, 1 thread | parallel, 2 threads |", "|:--|--:|--:|--:|"]
    for n in sorted({r["triangles"] for r in data["pile"]}):
        s, p = pile.get((n, "serial", 1)), pile.get((n, "parallel", 2))
        cell = lambda r: "" if r is None else f"{r['steps_per_s']:,.0f} ({n * r['steps_per_s'] / 1e6:.1f} M)"
        out.append(f"| resting pile of disks | {n:,} | {cell(s)} | {cell(p)} |")
    plate = {(r["triangles"], r["threads"]): r for r in data["plate"]}
    for n in sorted({r["triangles"] for r in data["plate"]}):
        a, b = plate.get((n, 1)), plate.get((n, 2))
        cell = lambda r: "" if r is None else _num(r["rate_first_window"], "{:.2f} M")
        out.append(f"| plate impact, every edge jointed, fragmenting | {n:,} | {cell(a)} | {cell(b)} |")
    y = data.get("y_family")
    # this project never fetches or runs code of the Y family: a figure appears here only when
    # results.json is given one measured elsewhere (its "y_family" entry)
    out.append("| serial C code of the Y family, same scenes | | "
               + ("not run here (this project does not fetch or run Y code)" if not y else y) + " | |")
    return "\n".join(out)


def lab_section(lab: dict | None) -> str:
    """Markdown of the lab tests at their defaults (``benchmarks/lab_defaults.py``): its command,
    set-up and tables, each table {"title", "text", "columns", "rows"} (cells already formatted;
    a column is right-aligned when its name starts with "=")."""
    if not lab:
        return ""
    out = ["", "## Lab tests at their defaults (`benchmarks/lab_defaults.py`)", "",
           f"`{lab['command']}`; measured {lab['date']} on {lab['host']}.", "", lab["setup"].strip()]
    for t in lab["tables"]:
        cols = [c.lstrip("=") for c in t["columns"]]
        align = ["---:" if c.startswith("=") else ":--" for c in t["columns"]]
        out += ["", f"### {t['title']}", ""]
        if t.get("text"):
            out += [t["text"].strip(), ""]
        out += ["| " + " | ".join(cols) + " |", "|" + "|".join(align) + "|"]
        out += ["| " + " | ".join(str(c) for c in row) + " |" for row in t["rows"]]
    return "\n".join(out) + "\n"


def calibration_table(rows: list[dict]) -> str:
    """Markdown: evaluations each calibration method needed to reach 2 % / 5 % per problem."""
    out = ["| problem | method | budget | evaluations run | to 2 % | to 5 % | error of the best |",
           "|:--|:--|--:|--:|--:|--:|:--|"]
    for r in rows:
        err = ", ".join(f"{k} {v * 100:+.2f} %" for k, v in r["best_error"].items())
        out.append(f"| {r['problem']} | {r['method']} | {r['budget']} | {r['evaluations']} | "
                   f"{r['to_2pc'] or '—'} | {r['to_5pc'] or '—'} | {err} |")
    return "\n".join(out)


def extra_sections(data: dict) -> str:
    """The sections after the README's table: the calibration comparison (``calibration``
    rows of ``benchmarks/calibration.py --json``) and the measured tables kept as text
    (``sections``: [{"title", "text"}])."""
    parts = []
    for sec in data.get("sections", []):
        parts.append(f"## {sec['title']}\n\n{sec['text']}\n")
    if data.get("calibration"):
        parts.append(f"""## Calibration methods (`benchmarks/calibration.py`)

`{data['calibration_command']}`

{data.get('calibration_note', '')}

{calibration_table(data['calibration'])}
""")
    return "".join("\n" + p for p in parts)


def write_markdown(data: dict, path: str = MD_PATH) -> str:
    """Write results.md from ``data`` (the content of results.json); returns the text."""
    st = data.get("startup", {})
    start = "; ".join(f"{s}: cold {v['cold_s']:.1f} s, warm {v['warm_s']:.1f} s" for s, v in st.items())
    text = f"""# Latest benchmark results

<!-- generated by benchmarks/report.py from benchmarks/results.json: do not edit -->

Host: {data['host']}; measured {data['date']}. On a shared host the same run varies by
10-20 %. What each benchmark runs and its columns: [README.md](README.md).

## Pile of disks (`benchmarks/pile.py`)

`{data['pile_command']}`

Steps/s over the timed run, M triangle-steps/s in brackets, the best of its windows in square
brackets.

{pile_table(data['pile'])}

Start-up to the first step of the 1k pile (empty / reused offline cache): {start}.

## Plate impact (`benchmarks/fracture.py`)

`{data['plate_command']}`

M triangle-steps/s.

{plate_table(data['plate'])}

## The README's table

{readme_table(data)}
{lab_section(data.get("lab"))}{extra_sections(data)}"""
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(text)
    return text


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pile", help="CSV of benchmarks/pile.py --csv: replaces the pile rows")
    ap.add_argument("--fracture", help="JSON of benchmarks/fracture.py --json: replaces the plate rows")
    ap.add_argument("--calibration", help="JSON of benchmarks/calibration.py --json: replaces the calibration rows")
    ap.add_argument("--lab", help="JSON of benchmarks/lab_defaults.py --json: replaces the lab tables")
    ap.add_argument("--host", help="the host the new rows were measured on")
    ap.add_argument("--date", help="the date of the new rows")
    ap.add_argument("--json", default=JSON_PATH, help="results.json to read and update")
    ap.add_argument("--out", default=MD_PATH, help="the Markdown file to write (default benchmarks/results.md)")
    ap.add_argument("--readme", action="store_true", help="also print the README's performance table")
    args = ap.parse_args(argv)
    with open(args.json) as fh:
        data = json.load(fh)
    changed = False
    if args.pile:
        rows = pile_rows_from_csv(args.pile)
        data["pile"] = rows
        for r in rows:
            if "cold_s" in r:
                data.setdefault("startup", {})[r["strategy"]] = {"cold_s": r.pop("cold_s"), "warm_s": r.pop("warm_s")}
        changed = True
    if args.fracture:
        data["plate"] = plate_rows_from_json(args.fracture)
        changed = True
    if args.calibration:
        with open(args.calibration) as fh:
            data["calibration"] = json.load(fh)
        changed = True
    if args.lab:
        with open(args.lab) as fh:
            data["lab"] = json.load(fh)
        changed = True
    for key in ("host", "date"):
        if getattr(args, key):
            data[key] = getattr(args, key)
            changed = True
    if changed:
        with open(args.json, "w") as fh:
            json.dump(data, fh, indent=1)
    write_markdown(data, args.out)
    print(f"wrote {args.out}")
    if args.readme:
        print(readme_table(data))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
