"""Algorithm comparison on the paper's two problems (the paper's reference [13]): Nelder-Mead
(sequential and parallel), differential evolution and the genetic algorithm, each with the same
evaluation budget and seed, run by `fmucal calibrate --workers 2`. Prints a Markdown table of
evaluations, rounds, wall time, final f and the largest relative parameter error against the
values that generated the data.

Usage: python bench/compare_algorithms.py FMUCAL_BINARY   (bash bench/compare_algorithms.sh)
"""
import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

BUDGET = 400
SEED = 7
repo = Path(__file__).resolve().parent.parent
fmucal = sys.argv[1]
problems = [
    ("Furuta (2 frictions)", repo / "examples/furuta/job.toml",
     {"armFriction": 0.010, "pendulumFriction": 0.0010}),
    ("Exhaust pipe, right volume (stage 1)", repo / "examples/exhaust/stage1_right.toml",
     {"rightVolume.wallCapacity": 24000.0, "rightVolume.wallConductance": 150.0}),
]
algorithms = [
    ("Nelder-Mead, sequential", 'algorithm = "nelder-mead"\nparallel = false'),
    ("Nelder-Mead, parallel", 'algorithm = "nelder-mead"\nparallel = true'),
    ("differential evolution", 'algorithm = "differential-evolution"\npopulation = 20'),
    ("genetic algorithm", 'algorithm = "genetic"\npopulation = 20\nelitism = 2'),
]

print(f"| problem | algorithm | evaluations | rounds | wall time, 2 workers [s] | final f | largest parameter error |")
print("|---|---|---|---|---|---|---|")
for pname, job, truth in problems:
    text = job.read_text()
    for aname, settings in algorithms:
        opt = f"[optimizer]\n{settings}\nx_tol = 1e-4\nf_tol = 1e-6\nmax_fevals = {BUDGET}\nseed = {SEED}\n\n"
        variant = re.sub(r"\[optimizer\].*?(?=\[workers\]|\Z)", opt, text, flags=re.S)
        with tempfile.TemporaryDirectory() as tmp:
            # Keep relative data paths working: write the variant beside the original.
            path = job.parent / f".compare-{Path(tmp).name}.toml"
            path.write_text(variant)
            try:
                subprocess.run([fmucal, "calibrate", str(path), "--workers", "2", "--out", tmp],
                               check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            finally:
                path.unlink()
            r = json.loads((Path(tmp) / "result.json").read_text())
        err = max(abs(r["x_opt"][k] - v) / abs(v) for k, v in truth.items())
        print(f"| {pname} | {aname} | {r['evaluations']} | {r['rounds']} | {r['elapsed_s']:.2f} | "
              f"{r['f_opt']:.4g} | {100 * err:.2f} % |")
