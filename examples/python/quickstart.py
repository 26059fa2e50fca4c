#!/usr/bin/env python3
"""The README's five Python lines, as a script: calibrates the paper's Furuta frictions locally
(the fmucal binary the package installed, worker processes, no coordinator), prints the optimum
with its standard errors, each output's RMS error and fit %, and saves the fit plot.

    pip install ./clients/python matplotlib
    python examples/python/quickstart.py            # from the repository's root, or anywhere
"""

from pathlib import Path

import fmucal_client as fmucal

JOB = Path(__file__).resolve().parent.parent / "furuta" / "job.toml"

result = fmucal.calibrate(JOB)
print(result)                                   # the optimum, standard errors, RMS and fit %
print("x_opt =", result.x_opt)
try:
    import matplotlib

    matplotlib.use("Agg")
except ImportError:
    print("(install matplotlib for the fit plot)")
else:
    result.plot().savefig("furuta_fit.png", dpi=110)
    print("wrote furuta_fit.png")
