"""Old/new throughput of the plate-impact benchmark in one run: whole benchmark processes of two
source trees, alternating, so that both see the same machine load.

    python benchmarks/ab.py OLD_TREE NEW_TREE [reps] [threads ...]

Each rep runs ``benchmarks/fracture.py --sizes 10000 --threads THREADS --profile-steps 0`` once
per tree (the tree's package first on PYTHONPATH) and reads its M triangle-steps/s over the whole
run; the medians and their ratio new/old are printed per thread setting.
"""
import json
import os
import statistics
import subprocess
import sys
import tempfile


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if len(argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    old, new = (os.path.abspath(p) for p in argv[:2])
    reps = int(argv[2]) if len(argv) > 2 else 3
    threads = argv[3:] or ["2"]
    res = {"old": [], "new": []}
    for r in range(reps):
        for tag, tree in (("old", old), ("new", new)):
            fd, js = tempfile.mkstemp(suffix=".json")
            os.close(fd)
            subprocess.run([sys.executable, "benchmarks/fracture.py", "--sizes", "10000", "--threads", *threads,
                            "--profile-steps", "0", "--json", js], cwd=tree, check=True, stdout=subprocess.DEVNULL,
                           env=dict(os.environ, PYTHONPATH=tree))
            with open(js) as fh:
                res[tag].append([row["rate_all"] for row in json.load(fh)])
            os.remove(js)
            print(r, tag, res[tag][-1], flush=True)
    for i, t in enumerate(threads):
        o = statistics.median(x[i] for x in res["old"])
        n = statistics.median(x[i] for x in res["new"])
        print(f"{t} thread(s): old {o:.4g} new {n:.4g} M tri-steps/s, new/old {n / o:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
