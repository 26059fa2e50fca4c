"""Adds seeded Gaussian noise of 1 % of the position's range to a `fmucal simulate` CSV
(time, mass.x) and writes the bench data (time, x). Standard library only."""

import csv
import random
import sys

rows = list(csv.reader(open(sys.argv[1])))
header, values = rows[0], [[float(v) for v in r] for r in rows[1:]]
x = [r[header.index("mass.x")] for r in values]
sigma = 0.01 * (max(x) - min(x))
noise = random.Random(27)
with open(sys.argv[2], "w") as out:
    out.write("time,x\n")
    for r, xi in zip(values, x):
        out.write(f"{r[0]:.2f},{xi + noise.gauss(0.0, sigma):.6f}\n")
