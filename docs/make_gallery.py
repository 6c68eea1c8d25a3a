"""The gallery: a still (PNG) and a short GIF of every demo, in ``docs/gallery/``.

Each demo of ``demos/`` runs in its short mode (``--short``, the mode the tests use) in its own
process, writing ``docs/gallery/NAME.gif``; its last frame is saved as ``NAME.png`` unless a
still is there already (the README shows stills of the full runs; ``--new-stills`` replaces them).

    python docs/make_gallery.py                # every demo (make gallery)
    python docs/make_gallery.py tunnel slope   # chosen demos

A demo that fails is reported and the others go on; the exit status is 1 if any failed.
"""
from __future__ import annotations

import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
DEMOS = os.path.join(ROOT, "demos")
GALLERY = os.path.join(HERE, "gallery")
#: demos that make no video of their own (the sweep and the calibration write a CSV and a plot)
NO_VIDEO = ("sweep_friction", "calibrate_granite")


def demo_names() -> list:
    """The demos of ``demos/`` that write a video, by name."""
    return sorted(f[:-3] for f in os.listdir(DEMOS)
                  if f.endswith(".py") and not f.startswith("_") and f[:-3] not in NO_VIDEO)


def make(name: str, timeout: float = 1800.0, new_still: bool = False) -> tuple:
    """Run one demo short, write its GIF and still; (ok, seconds, message)."""
    import imageio.v3 as iio
    gif = os.path.join(GALLERY, f"{name}.gif")
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    before = set(os.listdir(GALLERY))
    t0 = time.perf_counter()
    try:
        p = subprocess.run([sys.executable, os.path.join(DEMOS, f"{name}.py"), "--short", "--out", gif],
                           cwd=ROOT, env=env, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return False, time.perf_counter() - t0, f"timed out after {timeout:.0f} s"
    if p.returncode != 0 or not os.path.isfile(gif):
        tail = (p.stderr or p.stdout).strip().splitlines()[-3:]
        return False, time.perf_counter() - t0, " | ".join(tail)
    frames = iio.imread(gif, index=None)
    still = os.path.join(GALLERY, f"{name}.png")
    if new_still or not os.path.exists(still):
        iio.imwrite(still, frames[-1][..., :3])
    for extra in set(os.listdir(GALLERY)) - before - {f"{name}.gif", f"{name}.png"}:
        os.remove(os.path.join(GALLERY, extra))     # side outputs of the demo (histories, CSVs)
    return True, time.perf_counter() - t0, f"{len(frames)} frames"


def main(argv=None) -> int:
    args = list(argv if argv is not None else sys.argv[1:])
    new_stills = "--new-stills" in args
    names = [a for a in args if a != "--new-stills"] or demo_names()
    unknown = [n for n in names if n not in demo_names()]
    if unknown:
        print(f"unknown demo(s) {unknown}; choose from {demo_names()}", file=sys.stderr)
        return 2
    os.makedirs(GALLERY, exist_ok=True)
    failed = []
    for name in names:
        ok, seconds, msg = make(name, new_still=new_stills)
        print(f"{name:18s} {'ok' if ok else 'FAILED'}  {seconds:6.1f} s  {msg}", flush=True)
        if not ok:
            failed.append(name)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
