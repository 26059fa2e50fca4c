"""The rows the comparison benchmarks (bench/optim.sh, bench/least_squares.sh) tabulate."""
import json
import os


def ours_and_theirs(folder, reference):
    """fmucal's rows (``fmucal.json`` in ``folder``), in order, and the reference
    implementation's (file ``reference`` in ``folder``) by problem name."""
    ours = json.load(open(os.path.join(folder, "fmucal.json")))
    theirs = {r["problem"]: r for r in json.load(open(os.path.join(folder, reference)))}
    return ours, theirs
