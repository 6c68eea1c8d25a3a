"""The sweep's CSV table (:class:`_Table`): one row per point, appended and flushed as points
complete, read back to resume.
"""
from __future__ import annotations

import csv
import os

from .params import STATUS_COLUMNS, SweepError, _cell


# ----------------------------------------------------------------------------------------------
# the CSV table
# ----------------------------------------------------------------------------------------------
class _Table:
    """The sweep's CSV: rows appended and flushed as points complete; rewritten atomically when a
    new metric column appears or when resume drops rows that did not succeed."""

    def __init__(self, path: str, param_cols: list, resume: bool):
        self.path = os.fspath(path)
        self.param_cols = list(param_cols)
        self.metric_cols: list = []
        self.rows: list[dict] = []
        self._fh = None
        folder = os.path.dirname(os.path.abspath(self.path))
        os.makedirs(folder, exist_ok=True)
        if resume and os.path.exists(self.path) and os.path.getsize(self.path) > 0:
            self._read()
        self._rewrite()

    @property
    def columns(self) -> list:
        return self.param_cols + self.metric_cols + list(STATUS_COLUMNS)

    def _read(self) -> None:
        try:
            with open(self.path, newline="", encoding="utf-8") as f:
                reader = csv.DictReader(f)
                header = list(reader.fieldnames or [])
                rows = list(reader)
        except (OSError, csv.Error, UnicodeDecodeError) as exc:
            raise SweepError(f"{self.path}: cannot read the existing sweep table to resume: {exc}") from None
        missing = [c for c in self.param_cols + ["status"] if c not in header]
        if missing:
            raise SweepError(f"{self.path}: the existing table has columns {header} but this sweep needs "
                             f"{', '.join(missing)}: it belongs to another sweep; choose another output, "
                             f"or run with resume=False (--no-resume) to overwrite it")
        # metric columns are those that are neither parameters nor status columns
        self.metric_cols = [c for c in header if c not in self.param_cols and c not in STATUS_COLUMNS]
        for r in rows:
            if r.get("status") == "ok":
                self.rows.append({c: r.get(c, "") or "" for c in self.columns})

    def done_keys(self) -> set:
        return {tuple(r[c] for c in self.param_cols) for r in self.rows}

    def _open(self):
        if self._fh is None:
            self._fh = open(self.path, "a", newline="", encoding="utf-8")
        return self._fh

    def _rewrite(self) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None
        tmp = self.path + ".tmp"
        with open(tmp, "w", newline="", encoding="utf-8") as f:
            w = csv.DictWriter(f, fieldnames=self.columns)
            w.writeheader()
            for r in self.rows:
                w.writerow({c: r.get(c, "") for c in self.columns})
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, self.path)

    def append(self, params: dict, res: dict) -> dict:
        row = {c: _cell(params.get(c)) for c in self.param_cols}
        new = [k for k in res["metrics"] if k not in self.metric_cols and k not in self.param_cols]
        row.update({k: _cell(v) for k, v in res["metrics"].items()})
        row.update(status=res["status"], error=" ".join(str(res.get("error", "")).split()),
                   wall_s=f"{res.get('wall_s', 0.0):.4f}", worker=res.get("worker", ""))
        self.rows.append(row)
        if new:
            self.metric_cols += new
            self._rewrite()
        else:
            f = self._open()
            csv.DictWriter(f, fieldnames=self.columns).writerow({c: row.get(c, "") for c in self.columns})
            f.flush()
            os.fsync(f.fileno())
        return row

    def close(self) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None
