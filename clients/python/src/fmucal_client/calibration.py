"""The results of :func:`fmucal_client.calibrate`, :func:`~fmucal_client.diagnose` and
:func:`~fmucal_client.simulate` as typed, notebook-friendly objects.

A local calibration reads the folder ``fmucal calibrate --out`` writes: ``result.json`` (the
optimum, its standard errors and correlations, each output's RMS error and fit %, the
warnings, the history) and ``fit.csv`` (time, then ``NAME:measured``, ``NAME:start`` and
``NAME:optimized`` per output). A calibration on a coordinator (``coordinator=URL``) holds what
the coordinator reports: the optimum, its counts and warnings; the analysis after the fit
(standard errors, RMS errors, the fit table) is the CLI's and comes with local runs.

numpy is required; pandas (``to_pandas()``), matplotlib (``plot()``) and tqdm (progress bars)
are used when installed.
"""

from __future__ import annotations

import csv
import html
import json
import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from .results import JobResult

KINDS = ("measured", "start", "optimized")


def _number(v: Any) -> float:
    """A number of ``result.json``: ``null`` (NaN as serde_json writes it) and ``"inf"`` too."""
    if v is None:
        return math.nan
    if isinstance(v, str):
        return float(v)
    return float(v)


def _optional(module: str, purpose: str) -> Any:
    try:
        return __import__(module, fromlist=["_"])
    except ImportError as e:
        raise ImportError(f"{purpose} needs {module.split('.')[0]}: pip install {module.split('.')[0]}") from e


@dataclass(frozen=True)
class OutputError:
    """One output's errors in one window: RMS in the output's unit and fit %
    (``100·(1 − ‖y − ŷ‖/‖y − ȳ‖)``), of the model at the job's start values and at the optimum."""

    variable: str
    unit: str | None
    window: str
    """``calibration``, ``validation``, or ``whole span`` (an experiment not fitted)."""
    rms_start: float
    rms_optimized: float
    fit_percent_start: float
    fit_percent_optimized: float


@dataclass(frozen=True)
class WindowError:
    """A window's weighted RMS error, start and optimized, and their ratio ``scaled_rms``."""

    start_time: float
    stop_time: float
    rms_start: float
    rms_optimized: float
    scaled_rms: float

    @classmethod
    def from_json(cls, w: Mapping[str, Any]) -> WindowError:
        return cls(*(_number(w.get(k, w.get("rms_nominal") if k == "rms_start" else None))
                     for k in ("start_time", "stop_time", "rms_start", "rms_optimized", "scaled_rms")))


@dataclass(frozen=True)
class Errors:
    """An experiment's errors: its windows and each output's (``result.json``'s ``errors``)."""

    calibration: WindowError
    validation: WindowError | None
    outputs: list[OutputError]

    @classmethod
    def from_json(cls, e: Mapping[str, Any], first: str = "calibration") -> Errors:
        rows = []
        for o in e.get("outputs", []):
            for window, w in ((first, o.get("calibration")), ("validation", o.get("validation"))):
                if w is None:
                    continue
                start = w.get("rms_start", w.get("rms_nominal"))
                rows.append(OutputError(
                    o["variable"], o.get("unit"), window, _number(start), _number(w.get("rms_optimized")),
                    _number(w.get("fit_percent_start", w.get("fit_percent_nominal"))),
                    _number(w.get("fit_percent_optimized"))))
        validation = e.get("validation")
        return cls(WindowError.from_json(e["calibration"]),
                   WindowError.from_json(validation) if validation else None, rows)


@dataclass(frozen=True)
class Series:
    """One output of a fit table: measured, simulated at the start values and at the optimum
    (NaN where a value is missing)."""

    variable: str
    measured: np.ndarray
    start: np.ndarray
    optimized: np.ndarray


@dataclass(frozen=True)
class FitTable:
    """The fit table (``fit.csv``): the measurement times and, per output, a :class:`Series`."""

    time: np.ndarray
    outputs: dict[str, Series]

    def __getitem__(self, variable: str) -> Series:
        return self.outputs[variable]

    def __iter__(self) -> Iterator[str]:
        return iter(self.outputs)

    def __len__(self) -> int:
        return len(self.outputs)

    @classmethod
    def read(cls, path: Path) -> FitTable:
        """Reads a ``fit.csv`` (``NAME:nominal``, the old name of ``NAME:start``, too)."""
        with path.open(newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
        header, body = rows[0], rows[1:]
        values = np.array([[float(c) if c.strip() else math.nan for c in row] for row in body], dtype=float)
        values = values.reshape(len(body), len(header))
        columns = {name: values[:, k] for k, name in enumerate(header)}
        outputs: dict[str, Series] = {}
        for name in header[1:]:
            variable, _, kind = name.rpartition(":")
            if kind == "measured":
                start = columns.get(f"{variable}:start", columns.get(f"{variable}:nominal"))
                if start is None:
                    start = np.full(len(body), math.nan)
                outputs[variable] = Series(variable, columns[name], start, columns[f"{variable}:optimized"])
        return cls(columns[header[0]], outputs)

    def to_pandas(self) -> Any:
        """The table as a pandas DataFrame indexed by time, a column ``NAME:KIND`` per series."""
        pd = _optional("pandas", "to_pandas()")
        data = {}
        for s in self.outputs.values():
            for kind in KINDS:
                data[f"{s.variable}:{kind}"] = getattr(s, kind)
        return pd.DataFrame(data, index=pd.Index(self.time, name="time"))


@dataclass(frozen=True)
class Estimate:
    """A calibrated value with its standard error (NaN when not computed) and bounds."""

    name: str
    value: float
    standard_error: float
    lower: float
    upper: float


@dataclass(frozen=True)
class Experiment:
    """One experiment of a job with ``[[experiments]]``: its role, errors and fit table."""

    name: str
    role: str
    errors: Errors
    fit: FitTable | None


@dataclass(frozen=True)
class CalibrationResult:
    """A finished calibration.

    ``x_opt`` maps each calibrated name to its optimum, exactly as ``result.json`` holds it
    (the CLI's value to the last bit); ``standard_errors`` and ``correlation`` (a matrix in
    ``parameter_names`` order) come from the Jacobian at the optimum, ``rms`` and
    ``fit_percent`` per output from the comparison of the model with the data.
    """

    x_opt: dict[str, float]
    f_opt: float
    termination: str
    iterations: int
    evaluations: int
    rounds: int
    failed_evaluations: int
    elapsed_s: float
    warnings: list[str]
    standard_errors: dict[str, float] = field(default_factory=dict)
    parameter_names: list[str] = field(default_factory=list)
    correlation: np.ndarray | None = None
    bounds: dict[str, tuple[float, float]] = field(default_factory=dict)
    errors: Errors | None = None
    fit: FitTable | None = None
    experiments: list[Experiment] = field(default_factory=list)
    history: dict[str, np.ndarray] = field(default_factory=dict)
    """``round``, ``evaluations``, ``best_f`` and ``batch_wall_s`` per completed round."""
    raw: dict[str, Any] = field(default_factory=dict, repr=False)
    """``result.json`` as read (empty for a coordinator's result)."""
    summary: str = ""
    """What the CLI printed (local runs)."""

    @classmethod
    def read(cls, out: Path, summary: str = "") -> CalibrationResult:
        """Reads the folder ``fmucal calibrate --out`` wrote."""
        raw = json.loads((out / "result.json").read_text(encoding="utf-8"))
        ident = raw.get("identifiability") or {}
        names = list(ident.get("names", []))
        standard_errors = {n: _number(s) for n, s in zip(names, ident.get("standard_errors", []), strict=True)}
        correlation = (np.array([[_number(c) for c in row] for row in ident["correlation"]], dtype=float)
                       if ident.get("correlation") else None)
        experiments = []
        for x in raw.get("experiments", []):
            first = "calibration" if x.get("role", "fit") == "fit" else "whole span"
            fit_csv = out / x["name"] / "fit.csv"
            experiments.append(Experiment(x["name"], x.get("role", "fit"), Errors.from_json(x["errors"], first),
                                          FitTable.read(fit_csv) if fit_csv.is_file() else None))
        history = raw.get("history", [])
        return cls(
            x_opt={k: float(v) for k, v in raw["x_opt"].items()},
            f_opt=_number(raw.get("f_opt")),
            termination=raw.get("termination", ""),
            iterations=int(raw.get("iterations", 0)),
            evaluations=int(raw.get("evaluations", 0)),
            rounds=int(raw.get("rounds", 0)),
            failed_evaluations=int(raw.get("failed_evaluations", 0)),
            elapsed_s=_number(raw.get("elapsed_s")),
            warnings=list(raw.get("warnings", [])),
            standard_errors=standard_errors,
            parameter_names=names or [p["name"] for p in raw.get("parameters", [])] or list(raw["x_opt"]),
            correlation=correlation,
            bounds={p["name"]: (_number(p["lower"]), _number(p["upper"])) for p in raw.get("parameters", [])},
            errors=Errors.from_json(raw["errors"]) if raw.get("errors") else None,
            fit=FitTable.read(out / "fit.csv") if (out / "fit.csv").is_file() and not experiments else None,
            experiments=experiments,
            history={k: np.array([_number(h.get(k)) for h in history], dtype=float)
                     for k in ("round", "evaluations", "best_f", "batch_wall_s")},
            raw=raw,
            summary=summary,
        )

    @classmethod
    def from_job_result(cls, r: JobResult) -> CalibrationResult:
        """The result of a coordinator's job (no standard errors, RMS errors or fit table)."""
        return cls(x_opt=dict(r.x_opt), f_opt=r.f_opt, termination=r.termination, iterations=r.iterations,
                   evaluations=r.evaluations, rounds=r.rounds, failed_evaluations=r.failed_evaluations,
                   elapsed_s=r.elapsed_s, warnings=list(r.warnings), parameter_names=list(r.x_opt))

    @property
    def estimates(self) -> list[Estimate]:
        """Each calibrated value with its standard error and bounds, in calibrated order."""
        names = self.parameter_names or list(self.x_opt)
        return [Estimate(n, self.x_opt[n], self.standard_errors.get(n, math.nan),
                         *self.bounds.get(n, (math.nan, math.nan))) for n in names if n in self.x_opt]

    def correlations(self) -> dict[tuple[str, str], float]:
        """The correlation of each pair of different parameters, ``(a, b)`` in calibrated order."""
        if self.correlation is None:
            return {}
        n = self.parameter_names
        return {(n[i], n[j]): float(self.correlation[i, j]) for i in range(len(n)) for j in range(i + 1, len(n))}

    @property
    def outputs(self) -> list[OutputError]:
        """Each output's errors per window (of every experiment, for a job with several)."""
        if self.errors is not None:
            return self.errors.outputs
        return [o for x in self.experiments for o in x.errors.outputs]

    @property
    def rms(self) -> dict[str, float]:
        """Each output's RMS error at the optimum in the calibration window, in its unit."""
        return {o.variable: o.rms_optimized for o in self.outputs if o.window == "calibration"}

    @property
    def fit_percent(self) -> dict[str, float]:
        """Each output's fit % at the optimum in the calibration window."""
        return {o.variable: o.fit_percent_optimized for o in self.outputs if o.window == "calibration"}

    def to_pandas(self) -> Any:
        """The estimates as a pandas DataFrame: value, standard error, lower and upper bound."""
        pd = _optional("pandas", "to_pandas()")
        rows = self.estimates
        return pd.DataFrame({"value": [e.value for e in rows], "standard_error": [e.standard_error for e in rows],
                             "lower": [e.lower for e in rows], "upper": [e.upper for e in rows]},
                            index=pd.Index([e.name for e in rows], name="parameter"))

    def plot(self, *, experiment: str | None = None) -> Any:
        """Plots the fit: each output measured (dots), at the start values (dashed) and at the
        optimum (line), one panel per output; returns the matplotlib Figure.

        Raises:
            ValueError: no fit table (a coordinator's result), or no such experiment.
        """
        plt = _optional("matplotlib.pyplot", "plot()")
        fit = self.fit
        if experiment is not None or fit is None and self.experiments:
            chosen = [x for x in self.experiments if experiment in (None, x.name)]
            if not chosen:
                raise ValueError(f"no experiment {experiment!r}: {[x.name for x in self.experiments]}")
            fit = chosen[0].fit
        if fit is None:
            raise ValueError("this result has no fit table (a coordinator's result: run locally to get one)")
        units = self.raw.get("units", {})
        fig, axes = plt.subplots(len(fit), 1, figsize=(9, 2.8 * len(fit)), sharex=True, squeeze=False)
        for ax, s in zip(axes[:, 0], fit.outputs.values(), strict=True):
            ax.plot(fit.time, s.measured, ".", markersize=2, color="0.55", label="measured")
            ax.plot(fit.time, s.start, "--", linewidth=1, label="start")
            ax.plot(fit.time, s.optimized, linewidth=1.2, label="optimized")
            unit = units.get(s.variable)
            ax.set_ylabel(f"{s.variable} [{unit}]" if unit else s.variable)
            ax.grid(True, alpha=0.3)
        axes[0, 0].legend(loc="best")
        axes[-1, 0].set_xlabel("time [s]")
        fig.tight_layout()
        return fig

    def _rows(self) -> list[tuple[str, str, str]]:
        return [(e.name, f"{e.value:.6e}", "" if math.isnan(e.standard_error) else f"{e.standard_error:.2e}")
                for e in self.estimates]

    def __repr__(self) -> str:
        lines = [f"CalibrationResult({self.termination}; f_opt = {self.f_opt:.6e} after {self.evaluations} "
                 f"evaluations)"]
        for name, value, se in self._rows():
            lines.append(f"  {name} = {value}" + (f"  (standard error {se})" if se else ""))
        for variable in self.rms:
            lines.append(f"  {variable}: RMS {self.rms[variable]:.3e}, fit {self.fit_percent[variable]:.1f} %")
        lines.extend(f"  warning: {w}" for w in self.warnings)
        return "\n".join(lines)

    def _repr_html_(self) -> str:
        e = html.escape
        rows = "".join(f"<tr><td>{e(n)}</td><td>{v}</td><td>{se}</td></tr>" for n, v, se in self._rows())
        out = "".join(f"<tr><td>{e(o.variable)}</td><td>{e(o.window)}</td><td>{o.rms_optimized:.3e}</td>"
                      f"<td>{o.fit_percent_optimized:.1f}</td></tr>" for o in self.outputs)
        warn = "".join(f"<li>{e(w)}</li>" for w in self.warnings)
        return (f"<p><b>{e(self.termination)}</b>: f_opt = {self.f_opt:.6e} after {self.evaluations} evaluations"
                f" in {self.elapsed_s:.2f} s</p>"
                f"<table><tr><th>parameter</th><th>value</th><th>standard error</th></tr>{rows}</table>"
                + (f"<table><tr><th>output</th><th>window</th><th>RMS</th><th>fit %</th></tr>{out}</table>"
                   if out else "")
                + (f"<p>warnings:</p><ul>{warn}</ul>" if warn else ""))


@dataclass(frozen=True)
class Diagnosis:
    """A finished diagnosis: ``report`` is ``report.json``, ``job_toml`` the job with the named
    effects added (``job.toml``), ``summary`` what the CLI printed."""

    report: dict[str, Any]
    job_toml: str
    summary: str

    @property
    def named(self) -> list[str]:
        """The effects the diagnosis named, in words (empty when it named none)."""
        return [n.get("words", "") for n in self.report.get("named", [])]

    @property
    def fitted(self) -> dict[str, float]:
        """The final fit's values (base parameters and named effects)."""
        return {k: _number(v) for k, v in self.report.get("fitted", {}).items()}

    @property
    def standard_errors(self) -> dict[str, float]:
        """The final fit's standard errors."""
        return {k: _number(v) for k, v in self.report.get("standard_errors", {}).items()}

    @property
    def notes(self) -> list[str]:
        """The diagnosis's notes."""
        return list(self.report.get("notes", []))

    def __repr__(self) -> str:
        return self.summary.rstrip("\n") or f"Diagnosis(named={self.named})"

    def _repr_html_(self) -> str:
        return f"<pre>{html.escape(repr(self))}</pre>"


@dataclass(frozen=True)
class SimulationResult:
    """One simulation: the output times and each recorded variable's values."""

    time: np.ndarray
    values: dict[str, np.ndarray]

    def __getitem__(self, name: str) -> np.ndarray:
        return self.time if name == "time" else self.values[name]

    @classmethod
    def read(cls, path: Path) -> SimulationResult:
        """Reads the CSV ``fmucal simulate`` writes (time, then one column per variable)."""
        with path.open(newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
        header = rows[0]
        values = np.array([[float(c) for c in row] for row in rows[1:]], dtype=float).reshape(len(rows) - 1,
                                                                                            len(header))
        return cls(values[:, 0], {name: values[:, k] for k, name in enumerate(header) if k > 0})

    def to_pandas(self) -> Any:
        """A pandas DataFrame indexed by time."""
        pd = _optional("pandas", "to_pandas()")
        return pd.DataFrame(self.values, index=pd.Index(self.time, name="time"))

    def plot(self, *names: str) -> Any:
        """Plots the named variables (default all) against time; returns the Figure."""
        plt = _optional("matplotlib.pyplot", "plot()")
        fig, ax = plt.subplots(figsize=(9, 3.5))
        for name in names or tuple(self.values):
            ax.plot(self.time, self.values[name], label=name)
        ax.set_xlabel("time [s]")
        ax.legend(loc="best")
        ax.grid(True, alpha=0.3)
        fig.tight_layout()
        return fig

    def __repr__(self) -> str:
        span = f"{self.time[0]:g} to {self.time[-1]:g} s" if len(self.time) else "no rows"
        return f"SimulationResult({len(self.time)} rows, {span}: {', '.join(self.values)})"
