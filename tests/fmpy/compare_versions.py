"""Cross-checks the FMI 3.0 and FMI 1.0 builds of fmucal's example FMUs against their FMI 2.0
builds, with FMPy alone (fmucal is not involved): all are compiled from the same C model source
(models/c; the 3.0 one with -DFMUCAL_FMI3, the 1.0 ones with -DFMUCAL_FMI1=1 for Model Exchange
and -DFMUCAL_FMI1=2 for Co-Simulation), so FMPy must simulate them to the same results.

For each model <Identifier> and each case below it
  - runs FMPy's validate_fmu on the other versions' FMUs (<Identifier>Fmi3.fmu, and for the
    models of FMI1 <Identifier>Fmi1Me.fmu and <Identifier>Fmi1Cs.fmu), which must report no
    problems, and checks their fmiVersion (and, for 1.0, that each offers just its interface);
  - simulates <Identifier>.fmu (2.0) with fmpy.simulate_fmu in Model Exchange (CVode, rtol
    1e-8) and in Co-Simulation (communication step = output interval), and each other version
    in the same interface (for 1.0: the Model Exchange FMU in Model Exchange, the Co-Simulation
    FMU in Co-Simulation) on the same output grid, with the same inputs and start values (the
    cases of tests/fmpy_crosscheck.rs);
  - prints, per output and continuous state, the largest difference over the grid divided by
    the largest magnitude of the 2.0 result.
Model Exchange must agree to 1e-6 and Co-Simulation to 1e-9 (both run the same integrator on
the same equations), and both runs must have the same time grid; otherwise it exits with 1.

Usage: python compare_versions.py [--fmu-dir DIR]
DIR defaults to the newest target/*/build/fmucal-models-*/out/fmus of this repository.
"""
import argparse
import glob
import os
import sys

import numpy as np
from fmpy import read_model_description, simulate_fmu
from fmpy.validation import validate_fmu

ME_BOUND = 1e-6
CS_BOUND = 1e-9


def torque_profile():
    """The staircase arm torque and pendulum pulse of tests/fmpy_crosscheck.rs (torque_profile):
    levels held for 0.1 s, each jump written as two rows at the same time."""

    def level(k):
        return 0.05 * np.sin(0.05 * k), 0.01 if 100 <= k < 150 else 0.0

    rows = [(0.0, *level(0))]
    for k in range(1, 401):
        t = k / 10.0
        rows.append((t, *level(k - 1)))
        rows.append((t, *level(k)))
    dtype = [("time", np.float64), ("u", np.float64), ("pendulumJoint.tauExt", np.float64)]
    return np.array(rows, dtype=dtype)


# Models also built for FMI 1.0 (models/build.rs, FMI1); their 1.0 start values are the 2.0 ones.
FMI1 = {"Furuta", "BouncingBall", "Robertson"}
# Models built for FMI 1.0 Model Exchange only (StringsFmi1Me.fmu).
FMI1_ME_ONLY = {"Strings"}

# (identifier, case label, output interval, stop time, input signals or None,
#  start values for 2.0 (and 1.0), start values for 3.0)
CASES = [
    ("Furuta", "free swing", 0.01, 40.0, None, {}, {}),
    ("Furuta", "torque profile", 0.01, 40.0, torque_profile(), {}, {}),
    ("BouncingBall", "default", 0.01, 3.0, None, {}, {}),
    ("BouncingBall", "e = 0.8", 0.01, 3.0, None, {"e": 0.8}, {"e": 0.8}),
    ("Robertson", "default", 0.1, 40.0, None, {}, {}),
    # An array parameter: three scalars in 2.0, one Float64 array in 3.0.
    ("ArrayParams", "default", 0.01, 10.0, None, {}, {}),
    ("ArrayParams", "k = [1.5, 0.5, 2]", 0.01, 10.0, None,
     {"k[1]": 1.5, "k[2]": 0.5, "k[3]": 2.0}, {"k": [1.5, 0.5, 2.0]}),
    # A String parameter that scales the output y (y = len(String_parameter) x).
    ("Strings", "default", 0.01, 2.0, None, {}, {}),
    ("Strings", "String_parameter = ab", 0.01, 2.0, None, {"String_parameter": "ab"}, {"String_parameter": "ab"}),
    # A counter that terminates the simulation at t = 9 (before the stop time 10).
    ("Stair", "default", 0.2, 10.0, None, {}, {}),
]


def default_fmu_dir():
    repo = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
    dirs = glob.glob(os.path.join(repo, "target", "*", "build", "fmucal-models-*", "out", "fmus"))
    dirs = [d for d in dirs if glob.glob(os.path.join(d, "*Fmi3.fmu")) and glob.glob(os.path.join(d, "*Fmi1Me.fmu"))]
    if not dirs:
        sys.exit("no built FMI 3.0 and 1.0 fixtures under target/: run `cargo build --release -p fmucal-models`")
    return max(dirs, key=os.path.getmtime)


def compared_variables(md):
    """Numeric outputs, then continuous states that are not outputs (as
    tests/fmpy_crosscheck.rs)."""
    names = [v.name for v in md.modelVariables if v.causality == "output" and v.type not in ("String", "Binary")]
    for d in md.derivatives:
        state = d.variable.derivative
        if state is not None and state.name not in names:
            names.append(state.name)
    return names


def simulate(fmu, interface, interval, stop, signals, start_values, names):
    return simulate_fmu(
        fmu,
        fmi_type=interface,
        start_time=0.0,
        stop_time=stop,
        relative_tolerance=1e-8,
        output_interval=interval,
        input=signals,
        start_values=dict(start_values),
        output=names,
        record_events=False,
        validate=True,
    )


def others(ident, interface, start2, start3):
    """The builds compared with the 2.0 FMU in `interface`: (label, file, start values)."""
    out = [("3.0", f"{ident}Fmi3.fmu", start3)]
    if ident in FMI1:
        suffix = "Me" if interface == "ModelExchange" else "Cs"
        out.append(("1.0", f"{ident}Fmi1{suffix}.fmu", start2))
    elif ident in FMI1_ME_ONLY and interface == "ModelExchange":
        out.append(("1.0", f"{ident}Fmi1Me.fmu", start2))
    return out


def check_description(fmu_dir, file, failures):
    """FMPy's validation of one non-2.0 build, and its fmiVersion and interfaces."""
    path = os.path.join(fmu_dir, file)
    problems = validate_fmu(path)
    if problems:
        failures.append(f"{file}: FMPy's validation failed")
        print(f"{file}: FMPy validation failed:", *problems, sep="\n  ")
        return
    print(f"{file}: FMPy validation: no problems")
    md = read_model_description(path, validate=True)
    if file.endswith("Fmi3.fmu"):
        if md.fmiVersion != "3.0":
            failures.append(f"{file}: fmiVersion is {md.fmiVersion}")
    else:
        me = file.endswith("Me.fmu")
        if md.fmiVersion != "1.0":
            failures.append(f"{file}: fmiVersion is {md.fmiVersion}")
        if (md.modelExchange is not None) != me or (md.coSimulation is not None) == me:
            failures.append(f"{file}: offers the wrong interface for an FMI 1.0 {'ME' if me else 'CS'} FMU")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--fmu-dir", help="folder with the built .fmu files (fmucal_models::fmu_dir())")
    a = p.parse_args()
    fmu_dir = a.fmu_dir or default_fmu_dir()
    print(f"FMUs from {fmu_dir}")

    failures = []
    validated = set()
    worst = {}  # (version, interface) -> largest relative difference over all cases
    for ident, label, interval, stop, signals, start2, start3 in CASES:
        fmu2 = os.path.join(fmu_dir, f"{ident}.fmu")
        names = compared_variables(read_model_description(fmu2))
        for interface, bound in [("ModelExchange", ME_BOUND), ("CoSimulation", CS_BOUND)]:
            short = "ME" if interface == "ModelExchange" else "CS"
            r2 = simulate(fmu2, interface, interval, stop, signals, start2, names)
            t2 = np.asarray(r2["time"])
            for version, file, start in others(ident, interface, start2, start3):
                if file not in validated:
                    validated.add(file)
                    check_description(fmu_dir, file, failures)
                tag = f"{ident} {label} {short} {version}"
                r = simulate(os.path.join(fmu_dir, file), interface, interval, stop, signals, start, names)
                t = np.asarray(r["time"])
                if t2.shape != t.shape or np.max(np.abs(t2 - t)) > 1e-9:
                    failures.append(f"{tag}: the time grids differ ({t2.size} and {t.size} rows)")
                    print(f"{tag:<42} time grids differ: {t2.size} rows (2.0), {t.size} rows ({version})")
                    continue
                for name in names:
                    y2 = np.asarray(r2[name], dtype=np.float64)
                    y = np.asarray(r[name], dtype=np.float64)
                    scale = max(np.max(np.abs(y2)), 1e-300)
                    d = float(np.max(np.abs(y - y2)) / scale)
                    key = (version, short)
                    worst[key] = max(worst.get(key, 0.0), d)
                    verdict = "ok" if d <= bound else f"FAIL (bound {bound:.0e})"
                    print(f"{tag:<42} {name:<22} relative difference {d:.2e}  {verdict}")
                    if d > bound:
                        failures.append(f"{tag} {name}: {d:.2e} > {bound:.0e}")

    print("\nlargest relative difference to the FMI 2.0 build:")
    for (version, short), d in sorted(worst.items()):
        print(f"  FMI {version} {short}: {d:.2e} (bound {ME_BOUND if short == 'ME' else CS_BOUND:.0e})")
    if failures:
        print("\nthe FMI 2.0 builds and the other versions' builds disagree:", *failures, sep="\n  ")
        sys.exit(1)
    print("\nall FMI 3.0 and FMI 1.0 builds agree with their FMI 2.0 builds")


if __name__ == "__main__":
    main()
