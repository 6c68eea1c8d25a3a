"""Acoustic emission (AE) from crack events (pure NumPy).

* :func:`cluster_events` -- crack events closer than ``window_time`` in time **and**
  ``window_distance`` in space are linked; an AE event is a connected component of that
  proximity graph (single linkage, as the space-time clustering of Hazzard & Young 2000,
  Geophysics Research Letters 27(16), with their window = the crack's duration and radius).
  The events are sorted by time and swept (each is linked only to the later events of its
  time window, found by binary search), so the cost is O(n log n + P) for P candidate pairs.
* :func:`ae_events` -- per AE event: onset time, end time, location (energy-weighted
  centroid of its cracks), energy (sum of the released energies [J]), the seismic moment and
  the moment magnitude, the number of cracks and the mode.
* :func:`b_value` -- Aki's (1965) maximum-likelihood b-value of a magnitude sample.

Moment magnitude.  The seismic moment is estimated from the released energy E [J] with
Kanamori's (1977, J. Geophys. Res. 82(20)) ratio of radiated energy to moment,
E / M0 = Δσ / (2μ) ≈ 5·10⁻⁵, i.e. ``M0 = E / energy_to_moment`` [N·m], and
``M_w = (2/3) log10(M0) − 6.07`` (Hanks & Kanamori 1979, J. Geophys. Res. 84(B5), M0 in N·m).
Combined, ``M_w = (2/3) (log10 E − 4.8)``: the Gutenberg–Richter energy-magnitude relation.
The released joint energy is an upper bound of the radiated energy, so magnitudes compare
between runs and with the b-value, not in absolute terms with a lab's sensors.

Mode.  Each crack counts 1 (mode "I", tensile), 0 ("II", shear) or ½ ("I+II", "mixed"); an AE
event whose mean is ≥ 0.75 is "tensile", ≤ 0.25 "shear", otherwise "mixed".
"""
from __future__ import annotations

import csv
import os

import numpy as np

__all__ = ["cluster_events", "ae_events", "b_value", "write_ae_events", "AE_CSV_COLUMNS",
           "ENERGY_TO_MOMENT"]

#: Kanamori (1977): radiated energy / seismic moment = Δσ / (2μ) for Δσ/μ ≈ 10⁻⁴
ENERGY_TO_MOMENT = 5.0e-5
#: columns of an AE-event CSV file, with units in their names
AE_CSV_COLUMNS = ("event", "time_s", "end_s", "x_m", "y_m", "energy_J", "moment_Nm", "magnitude",
                  "cracks", "mode")
_KEYS = ("event", "time", "end", "x", "y", "energy", "moment", "magnitude", "cracks", "mode")
_MODE_SCORE = {"I": 1.0, "II": 0.0, "I+II": 0.5, "mixed": 0.5}
_PAIR_CHUNK = 1 << 20


def _positive(value, name: str, where: str) -> float:
    v = float(value)
    if not np.isfinite(v) or v <= 0:
        raise ValueError(f"{where}: {name} must be a positive number, got {value!r}")
    return v


def _components(n: int, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Connected-component label (the smallest member index) of nodes 0..n-1 with edges u-v:
    vectorised hooking and pointer jumping."""
    parent = np.arange(n)
    while True:
        while True:
            p2 = parent[parent]
            if np.array_equal(p2, parent):
                break
            parent = p2
        ru, rv = parent[u], parent[v]
        differ = ru != rv
        if not differ.any():
            return parent
        u, v = u[differ], v[differ]
        lo, hi = np.minimum(ru[differ], rv[differ]), np.maximum(ru[differ], rv[differ])
        np.minimum.at(parent, hi, lo)


def cluster_events(time, x, y, window_time: float, window_distance: float) -> np.ndarray:
    """AE-event id (0, 1, ... in order of each event's first crack in time) of every crack
    event: connected components of the graph linking events i, j with
    ``|t_i − t_j| <= window_time`` [s] and ``|x_i − x_j| <= window_distance`` [m].

    ``time``, ``x``, ``y`` : (n,) arrays [s], [m]; returns (n,) int64 in the input order."""
    where = "cluster_events"
    t = np.asarray(time, np.float64).ravel()
    x = np.asarray(x, np.float64).ravel()
    y = np.asarray(y, np.float64).ravel()
    if not (len(t) == len(x) == len(y)):
        raise ValueError(f"{where}: time, x and y must have the same length, got {len(t)}, {len(x)}, {len(y)}")
    if not (np.isfinite(t).all() and np.isfinite(x).all() and np.isfinite(y).all()):
        raise ValueError(f"{where}: time, x and y must be finite")
    wt = float(window_time)
    if not np.isfinite(wt) or wt < 0:
        raise ValueError(f"{where}: window_time must be >= 0, got {window_time!r}")
    wd = _positive(window_distance, "window_distance", where)
    n = len(t)
    if n == 0:
        return np.zeros(0, np.int64)
    order = np.argsort(t, kind="stable")
    ts, xs, ys = t[order], x[order], y[order]
    hi = np.searchsorted(ts, ts + wt, side="right")        # events i+1 .. hi-1 are in i's window
    count = hi - np.arange(n) - 1
    us, vs = [], []
    start = 0
    while start < n:                                       # chunks of about _PAIR_CHUNK pairs
        csum = np.cumsum(count[start:])
        stop = start + max(1, int(np.searchsorted(csum, _PAIR_CHUNK)))
        c = count[start:stop]
        i = np.repeat(np.arange(start, stop), c)
        off = np.arange(int(c.sum())) - np.repeat(np.cumsum(c) - c, c)
        j = i + 1 + off
        near = (xs[i] - xs[j]) ** 2 + (ys[i] - ys[j]) ** 2 <= wd * wd
        us.append(i[near])
        vs.append(j[near])
        start = stop
    root = _components(n, np.concatenate(us), np.concatenate(vs))
    # root = smallest sorted index of the component = its first crack in time
    _, ids = np.unique(root, return_inverse=True)
    out = np.empty(n, np.int64)
    out[order] = ids
    return out


def ae_events(events: dict, window_time: float, window_distance: float,
              energy_to_moment: float = ENERGY_TO_MOMENT) -> dict:
    """AE events of crack events (the dict of ``sim.cracks.events()`` or
    ``read_crack_events``: ``time``, ``x``, ``y``, ``energy``, ``mode``), clustered by
    :func:`cluster_events`.

    Returns a dict of (N,) arrays in time order: ``event`` (id), ``time`` [s] (first crack),
    ``end`` [s] (last crack), ``x``, ``y`` [m] (energy-weighted centroid; the plain mean when
    the energies are all zero), ``energy`` [J], ``moment`` [N·m] (``energy / energy_to_moment``),
    ``magnitude`` (M_w, Hanks & Kanamori 1979; −inf for zero energy), ``cracks`` (count),
    ``mode`` ("tensile", "shear", "mixed"), and ``crack_event`` (n,) the AE id of every crack."""
    where = "ae_events"
    e2m = _positive(energy_to_moment, "energy_to_moment", where)
    for k in ("time", "x", "y", "energy", "mode"):
        if k not in events:
            raise ValueError(f"{where}: the crack events lack {k!r} (give sim.cracks.events() or read_crack_events())")
    label = cluster_events(events["time"], events["x"], events["y"], window_time, window_distance)
    t = np.asarray(events["time"], np.float64)
    e = np.asarray(events["energy"], np.float64)
    modes = np.asarray(events["mode"], dtype=object)
    unknown = sorted(set(modes.tolist()) - set(_MODE_SCORE))
    if unknown:
        raise ValueError(f"{where}: unknown crack mode(s) {unknown} (expected {sorted(_MODE_SCORE)})")
    score = np.array([_MODE_SCORE[m] for m in modes.tolist()], np.float64)
    N = int(label.max()) + 1 if len(label) else 0
    cnt = np.bincount(label, minlength=N).astype(np.int64)
    energy = np.bincount(label, e, minlength=N)
    w = np.where(energy[label] > 0, e, 1.0)
    wsum = np.bincount(label, w, minlength=N)
    x = np.bincount(label, w * np.asarray(events["x"], np.float64), minlength=N) / np.maximum(wsum, 1e-300)
    y = np.bincount(label, w * np.asarray(events["y"], np.float64), minlength=N) / np.maximum(wsum, 1e-300)
    start = np.full(N, np.inf)
    np.minimum.at(start, label, t)
    end = np.full(N, -np.inf)
    np.maximum.at(end, label, t)
    mean_score = np.bincount(label, score, minlength=N) / np.maximum(cnt, 1)
    mode = np.where(mean_score >= 0.75, "tensile", np.where(mean_score <= 0.25, "shear", "mixed")).astype(object)
    moment = energy / e2m
    with np.errstate(divide="ignore"):
        mag = np.where(moment > 0, (2.0 / 3.0) * np.log10(np.maximum(moment, 1e-300)) - 6.07, -np.inf)
    return {"event": np.arange(N, dtype=np.int64), "time": start, "end": end, "x": x, "y": y,
            "energy": energy, "moment": moment, "magnitude": mag, "cracks": cnt, "mode": mode,
            "crack_event": label}


def b_value(magnitudes, completeness: float | None = None, bin_width: float = 0.0) -> tuple:
    """Aki's (1965) maximum-likelihood b-value of the Gutenberg–Richter law
    log10 N(≥M) = a − b M: ``b = log10(e) / (mean(M) − (M_c − bin_width / 2))`` over the
    magnitudes M ≥ M_c (Utsu's correction for magnitudes binned by ``bin_width``).

    completeness : M_c (default: the smallest finite magnitude).  Returns ``(b, sigma, n)``:
    the estimate, Aki's standard error ``b / sqrt(n)`` and the number of magnitudes used."""
    where = "b_value"
    m = np.asarray(magnitudes, np.float64).ravel()
    m = m[np.isfinite(m)]
    if len(m) < 2:
        raise ValueError(f"{where}: needs at least 2 finite magnitudes, got {len(m)}")
    mc = float(m.min()) if completeness is None else float(completeness)
    dm = float(bin_width)
    if not np.isfinite(dm) or dm < 0:
        raise ValueError(f"{where}: bin_width must be >= 0, got {bin_width!r}")
    m = m[m >= mc]
    if len(m) < 2:
        raise ValueError(f"{where}: fewer than 2 magnitudes at or above the completeness {mc}")
    excess = float(m.mean()) - (mc - 0.5 * dm)
    if excess <= 0:
        raise ValueError(f"{where}: all magnitudes equal the completeness {mc}: b is undefined")
    b = np.log10(np.e) / excess
    return float(b), float(b / np.sqrt(len(m))), int(len(m))


def write_ae_events(path, ae: dict) -> str:
    """Write the AE events of :func:`ae_events` as CSV (columns :data:`AE_CSV_COLUMNS`); returns the path."""
    path = os.fspath(path)
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    tmp = path + ".tmp"
    with open(tmp, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(AE_CSV_COLUMNS)
        w.writerows(zip(*[np.asarray(ae[k]).tolist() for k in _KEYS]))
    os.replace(tmp, path)
    return path
