"""Times FMPy's simulate_fmu on an FMU extracted once (so unzipping is not timed), median of
--repeat runs, and prints JSON {"seconds": ..., "rows": ...}. Used by bench/runtime.sh."""
import argparse
import json
import shutil
import time

from fmpy import extract, simulate_fmu

p = argparse.ArgumentParser()
p.add_argument("--fmu", required=True)
p.add_argument("--stop", type=float, required=True)
p.add_argument("--interval", type=float, required=True)
p.add_argument("--rtol", type=float, default=1e-6)
p.add_argument("--repeat", type=int, default=3)
a = p.parse_args()

unzipdir = extract(a.fmu)
times = []
rows = 0
for _ in range(a.repeat):
    t = time.perf_counter()
    r = simulate_fmu(unzipdir, fmi_type="ModelExchange", stop_time=a.stop, output_interval=a.interval,
                     relative_tolerance=a.rtol, record_events=False)
    times.append(time.perf_counter() - t)
    rows = len(r)
shutil.rmtree(unzipdir, ignore_errors=True)
times.sort()
print(json.dumps({"seconds": times[len(times) // 2], "rows": rows}))
