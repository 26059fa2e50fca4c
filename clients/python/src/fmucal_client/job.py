"""The job, read from a TOML job file or a dict of the same structure, as the CLI reads it.

:func:`load_job` reads every field of the README's job-file reference (``[model]``, ``[data]``,
``[[outputs]]``, ``[[inputs]]``, ``[[parameters]]``, ``[[effects]]``, ``[simulation]`` with
``set`` and ``set_from``, ``[optimizer]``, ``[workers]``, ``[[experiments]]``) into a
:class:`JobSpec`. Unknown fields and values of the wrong type are refused naming the field
(``parameters[1].lower: expected a number, got 'abc' (a string)``), and the closed choices
(algorithm, interface, solver, scale, role) are checked and written in their canonical form,
as the CLI's reader does. Relative paths are resolved against the job file's folder (a dict's
``base_dir``); ``example:NAME`` is left for :mod:`fmucal_client.models`.

What the coordinator checks against the model and data (bounds, variable names, weights) is
left to it: its INVALID_ARGUMENT names the same fields. ``[diagnose]`` is accepted and ignored
(it is not part of a calibration job). ``[workers] count`` is read but not sent (it sizes the
CLI's local runs).
"""

from __future__ import annotations

import json
import os
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from ._fields import Table, describe, join, to_number
from .errors import JobFileError

ALGORITHMS = ("nelder-mead", "differential-evolution", "genetic", "cma-es", "least-squares")
INTERFACES = ("me", "cs")
SCALES = ("linear", "log")
ROLES = ("fit", "validation")
# The CLI reads solvers case-insensitively, with two aliases.
SOLVERS = {"bdf": "bdf", "esdirk34": "esdirk34", "tr-bdf2": "tr-bdf2", "trbdf2": "tr-bdf2", "tsit45": "tsit45",
           "explicit": "tsit45"}

SetValue = float | bool | str
"""A fixed value of ``[simulation] set``: a number, a boolean, or text (enumeration items)."""


@dataclass(frozen=True)
class ModelRef:
    """``[model]``: a file (or ``example:NAME``), or the id of an uploaded model."""

    path: Path | str | None
    id: str | None
    interface: str | None


@dataclass(frozen=True)
class DataRef:
    """``[data]`` (or an experiment's ``data``): the measurement file and its time column."""

    path: Path | str | None
    time_column: str = "time"


@dataclass(frozen=True)
class OutputMap:
    """An ``[[outputs]]`` entry: FMU variable, data column and weight (default 1)."""

    variable: str
    column: str
    weight: float = 1.0


@dataclass(frozen=True)
class InputMap:
    """An ``[[inputs]]`` entry: data column to FMU input."""

    column: str
    variable: str


@dataclass(frozen=True)
class Parameter:
    """A ``[[parameters]]`` entry."""

    name: str
    start: float
    lower: float
    upper: float
    per_experiment: bool = False
    scale: str = "linear"


@dataclass(frozen=True)
class Bounds:
    """Start value and bounds of an effect's parameter."""

    start: float
    lower: float
    upper: float


@dataclass(frozen=True)
class Effect:
    """An ``[[effects]]`` entry: a kind of fmucal's library, what it acts on (a continuous
    ``state`` in Model Exchange, a ``port`` and ``signal``, a mapped ``output`` or ``input``), its
    parameters. A mechanical state effect may name a ``reaction``: a coupled velocity state whose
    derivative gets the same term at the strength of parameter ``reaction``."""

    kind: str
    port: str | None
    signal: str | None
    output: str | None
    input: str | None
    parameters: dict[str, Bounds]
    state: str | None = None
    reaction: str | None = None


@dataclass(frozen=True)
class Simulation:
    """``[simulation]``, with ``set_from`` already merged into ``set``."""

    start_time: float | None = None
    stop_time: float | None = None
    tolerance: float | None = None
    solver: str | None = None
    set: dict[str, SetValue] = field(default_factory=dict)
    validation_stop_time: float | None = None


@dataclass(frozen=True)
class NelderMead:
    """Nelder–Mead's options (``algorithm = "nelder-mead"``, and the default algorithm's)."""

    parallel: bool = True
    initial_step: float | None = None


@dataclass(frozen=True)
class DifferentialEvolution:
    """Differential evolution's options (``algorithm = "differential-evolution"``)."""

    population: int | None = None
    weight: float | None = None
    crossover: float | None = None


@dataclass(frozen=True)
class Genetic:
    """The genetic algorithm's options (``algorithm = "genetic"``)."""

    population: int | None = None
    bits: int | None = None
    crossover_rate: float | None = None
    mutation_rate: float | None = None
    elitism: int | None = None


@dataclass(frozen=True)
class CmaEs:
    """CMA-ES's options (``algorithm = "cma-es"``)."""

    initial_step: float | None = None
    population: int | None = None
    restarts: int | None = None


@dataclass(frozen=True)
class LeastSquares:
    """The least-squares solver's options (``algorithm = "least-squares"``)."""

    initial_step: float | None = None


AlgorithmOptions = NelderMead | DifferentialEvolution | Genetic | CmaEs | LeastSquares
"""One algorithm's own options."""

#: The options type of each algorithm.
OPTIONS_OF: dict[str, type] = {
    "nelder-mead": NelderMead,
    "differential-evolution": DifferentialEvolution,
    "genetic": Genetic,
    "cma-es": CmaEs,
    "least-squares": LeastSquares,
}


@dataclass(frozen=True)
class Optimizer:
    """``[optimizer]``: the settings every algorithm shares, and the algorithm with its own
    options (``options``, of the algorithm's type: :class:`NelderMead` when ``algorithm`` is
    ``None``). ``None`` leaves a setting at the optimizer's default."""

    #: ``None``: the default algorithm (Nelder–Mead), sent as none, as the CLI does.
    algorithm: str | None = None
    options: AlgorithmOptions = field(default_factory=NelderMead)
    x_tol: float | None = None
    f_tol: float | None = None
    max_iters: int | None = None
    max_fevals: int | None = None
    max_time: float | None = None
    seed: int = 0

    def __post_init__(self) -> None:
        expected = OPTIONS_OF.get(self.algorithm or "nelder-mead")
        if expected is None or type(self.options) is not expected:
            raise ValueError(f"algorithm {self.algorithm!r} takes {expected.__name__ if expected else 'no'} options, "
                             f"not {type(self.options).__name__}")


#: The settings of :class:`Optimizer` that every algorithm shares, as the job file, the
#: protocol and :class:`Optimizer` name them.
SHARED_SETTINGS = ("x_tol", "f_tol", "max_iters", "max_fevals", "max_time", "seed")


@dataclass(frozen=True)
class Experiment:
    """An ``[[experiments]]`` entry; ``None`` takes the job's value."""

    name: str
    role: str = "fit"
    data: DataRef | None = None
    outputs: list[OutputMap] | None = None
    inputs: list[InputMap] | None = None
    set: dict[str, SetValue] = field(default_factory=dict)
    start_time: float | None = None
    stop_time: float | None = None
    validation_stop_time: float | None = None
    starts: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class JobSpec:
    """A whole job, as the CLI holds it after reading the file."""

    model: ModelRef
    data: DataRef
    outputs: list[OutputMap]
    inputs: list[InputMap]
    parameters: list[Parameter]
    effects: list[Effect]
    simulation: Simulation
    optimizer: Optimizer
    experiments: list[Experiment]
    workers: int | None = None


def load_job(job: Mapping[str, Any] | str | os.PathLike[str], base_dir: str | os.PathLike[str] | None = None) -> JobSpec:
    """Reads a job: the path of a TOML job file, or a dict with the file's structure.

    Relative paths are resolved against the file's folder, or ``base_dir`` (default: the
    current folder) for a dict.

    Raises:
        JobFileError: naming the field (``toml`` for TOML syntax, with the line).
    """
    if isinstance(job, Mapping):
        return parse_job(job, Path(base_dir) if base_dir is not None else Path.cwd())
    path = Path(job)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise JobFileError("job", f"cannot read {path}: {e}") from e
    try:
        table = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise JobFileError("toml", f"{path}: {e}") from e
    return parse_job(table, Path(base_dir) if base_dir is not None else path.parent)


def parse_job(table: Mapping[str, Any], base_dir: Path) -> JobSpec:
    """Reads a job from its TOML table; relative paths are resolved against ``base_dir``.

    Raises:
        JobFileError: naming the field.
    """
    top = Table(table, "", ("model", "data", "outputs", "inputs", "parameters", "effects", "simulation",
                            "optimizer", "workers", "diagnose", "experiments"))
    model = Table(top.require("model"), "model", ("path", "id", "interface"))
    data = top.table("data", ("path", "time_column"))
    outputs = top.tables("outputs", ("variable", "column", "weight"))
    if outputs is None:
        raise JobFileError("outputs", "missing")
    workers = top.table("workers", ("count",))
    top.mapping("diagnose")  # a table, read by `fmucal diagnose` only
    return JobSpec(
        model=ModelRef(
            path=_path(model.text("path"), base_dir),
            id=model.text("id"),
            interface=_choice(model, "interface", INTERFACES),
        ),
        data=_data(data, base_dir) if data is not None else DataRef(None),
        outputs=[_output(t) for t in outputs],
        inputs=[_input(t) for t in top.tables("inputs", ("column", "variable")) or []],
        parameters=[_parameter(t) for t in top.tables("parameters", PARAMETER_FIELDS) or []],
        effects=[_effect(t) for t in top.tables("effects", ("kind", "state", "reaction", "port", "signal",
                                                             "output", "input", "parameters")) or []],
        simulation=_simulation(top.table("simulation", SIMULATION_FIELDS), base_dir),
        optimizer=_optimizer(top.table("optimizer", OPTIMIZER_FIELDS)),
        experiments=[_experiment(t, base_dir) for t in top.tables("experiments", EXPERIMENT_FIELDS) or []],
        workers=workers.count("count") if workers is not None else None,
    )


PARAMETER_FIELDS = ("name", "start", "lower", "upper", "per_experiment", "scale")
SIMULATION_FIELDS = ("start_time", "stop_time", "tolerance", "tolerance_guard", "solver", "set", "set_from",
                     "validation_stop_time")
OPTIMIZER_FIELDS = ("algorithm", "parallel", "x_tol", "f_tol", "max_iters", "max_fevals", "max_time", "seed", "initial_step",
                    "population", "restarts", "weight", "crossover", "bits", "crossover_rate", "mutation_rate",
                    "elitism")
# The algorithms that take each option of the flat ``[optimizer]`` table, in the CLI's order.
TAKEN_BY = {
    "parallel": ("nelder-mead",),
    "initial_step": ("nelder-mead", "cma-es", "least-squares"),
    "population": ("differential-evolution", "genetic", "cma-es"),
    "restarts": ("cma-es",),
    "weight": ("differential-evolution",),
    "crossover": ("differential-evolution",),
    "bits": ("genetic",),
    "crossover_rate": ("genetic",),
    "mutation_rate": ("genetic",),
    "elitism": ("genetic",),
}
EXPERIMENT_FIELDS = ("name", "role", "data", "outputs", "inputs", "set", "start_time", "stop_time",
                     "validation_stop_time", "starts")


def quote(text: str) -> str:
    """Text in double quotes, as the CLI's messages quote it."""
    return json.dumps(text, ensure_ascii=False)


def _choice(t: Table, name: str, choices: tuple[str, ...]) -> str | None:
    value = t.text(name)
    if value is not None and value not in choices:
        listed = ", ".join(choices[:-1]) + f" or {choices[-1]}"
        raise JobFileError(t.field(name), f"{quote(value)} is not {listed}")
    return value


def _path(text: str | None, base_dir: Path) -> Path | str | None:
    """A path as written, resolved against ``base_dir``; ``example:NAME`` is kept as text."""
    if text is None or text.startswith("example:"):
        return text
    path = Path(text)
    return path if path.is_absolute() else base_dir / path


def _data(t: Table, base_dir: Path) -> DataRef:
    time_column = t.text("time_column")
    return DataRef(_path(t.text("path"), base_dir), "time" if time_column is None else time_column)


def _output(t: Table) -> OutputMap:
    weight = t.number("weight")
    return OutputMap(t.required_text("variable"), t.required_text("column"), 1.0 if weight is None else weight)


def _input(t: Table) -> InputMap:
    return InputMap(t.required_text("column"), t.required_text("variable"))


def _parameter(t: Table) -> Parameter:
    return Parameter(
        name=t.required_text("name"),
        start=t.required_number("start"),
        lower=t.required_number("lower"),
        upper=t.required_number("upper"),
        per_experiment=t.flag("per_experiment", False),
        scale=_choice(t, "scale", SCALES) or "linear",
    )


def _effect(t: Table) -> Effect:
    kind = t.required_text("kind")
    t.require("parameters")
    parameters = {}
    for name, value in t.mapping("parameters").items():
        b = Table(value, join(t.field("parameters"), name), ("start", "lower", "upper"))
        parameters[name] = Bounds(b.required_number("start"), b.required_number("lower"), b.required_number("upper"))
    return Effect(
        kind=kind,
        port=t.text("port"),
        signal=t.text("signal"),
        output=t.text("output"),
        input=t.text("input"),
        parameters=parameters,
        state=t.text("state"),
        reaction=t.text("reaction"),
    )


def _set_values(t: Table, name: str) -> dict[str, SetValue]:
    values: dict[str, SetValue] = {}
    for key, value in t.mapping(name).items():
        if isinstance(value, bool) or isinstance(value, str):
            values[key] = value
        elif type(value) in (int, float):
            values[key] = float(value)
        else:
            raise JobFileError(join(t.field(name), key), f"expected a number, true/false or a string, got {describe(value)}")
    return values


def _solver(t: Table) -> str | None:
    value = t.text("solver")
    if value is None:
        return None
    if value.lower() not in SOLVERS:
        raise JobFileError(t.field("solver"),
                           f"unknown solver {quote(value.lower())} (expected bdf, esdirk34, tr-bdf2 or tsit45)")
    return SOLVERS[value.lower()]


def _simulation(t: Table | None, base_dir: Path) -> Simulation:
    if t is None:
        return Simulation()
    values = _set_values(t, "set")
    # The tolerance guard runs in `fmucal calibrate` (it simulates the model locally); a job
    # sent from Python runs at the job's tolerance. The value is still checked.
    t.flag("tolerance_guard", True)
    set_from = t.text("set_from")
    if set_from is not None:
        for name, value in _earlier_optimum(base_dir / set_from, t.field("set_from")).items():
            values.setdefault(name, value)
    return Simulation(
        start_time=t.number("start_time"),
        stop_time=t.number("stop_time"),
        tolerance=t.number("tolerance"),
        solver=_solver(t),
        set=values,
        validation_stop_time=t.number("validation_stop_time"),
    )


def _earlier_optimum(path: Path, field_name: str) -> dict[str, float]:
    """The ``x_opt`` of an earlier calibration's ``result.json`` (``set_from``)."""
    try:
        result = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as e:
        raise JobFileError(field_name, f"cannot read {path}: {e}") from e
    x_opt = result.get("x_opt") if isinstance(result, dict) else None
    if not isinstance(x_opt, dict):
        raise JobFileError(field_name, f"cannot read {path}: it has no x_opt table")
    return {name: to_number(v, f"{field_name}: {path}: x_opt.{name}") for name, v in x_opt.items()}


def _optimizer(t: Table | None) -> Optimizer:
    if t is None:
        return Optimizer()
    algorithm = _choice(t, "algorithm", ALGORITHMS)
    flat = {
        "parallel": t.flag("parallel", True),
        "x_tol": t.number("x_tol"),
        "f_tol": t.number("f_tol"),
        "max_iters": t.count("max_iters"),
        "max_fevals": t.count("max_fevals"),
        "max_time": t.number("max_time"),
        "seed": t.count("seed") or 0,
        "initial_step": t.number("initial_step"),
        "population": t.count("population"),
        "restarts": t.count("restarts", bits=32),
        "weight": t.number("weight"),
        "crossover": t.number("crossover"),
        "bits": t.count("bits", bits=32),
        "crossover_rate": t.number("crossover_rate"),
        "mutation_rate": t.number("mutation_rate"),
        "elitism": t.count("elitism"),
    }
    runs = algorithm or "nelder-mead"
    # An option of another algorithm is refused, as the CLI refuses it (`parallel` only when
    # false: every job the CLI writes back says `parallel = true`).
    for name, takers in TAKEN_BY.items():
        given = flat[name] is False if name == "parallel" else flat[name] is not None
        if given and runs not in takers:
            listed = takers[0] if len(takers) == 1 else ", ".join(takers[:-1]) + f" or {takers[-1]}"
            default = "" if algorithm is not None else " (the default algorithm)"
            raise JobFileError(t.field(name), f"applies to {listed}, not {runs}{default}")
    options_type = OPTIONS_OF[runs]
    options = options_type(**{f.name: flat[f.name] for f in fields(options_type)})
    return Optimizer(algorithm=algorithm, options=options, **{name: flat[name] for name in SHARED_SETTINGS})


def optimizer_table(o: Optimizer) -> dict[str, Any]:
    """The flat ``[optimizer]`` table of ``o``, every field in the job file's order (unset
    options ``None``; ``parallel`` true for the algorithms without it), as the CLI writes it."""
    values = {"algorithm": o.algorithm, "parallel": True, **{name: getattr(o, name) for name in SHARED_SETTINGS}}
    values.update({f.name: getattr(o.options, f.name) for f in fields(o.options)})
    return {name: values.get(name) for name in OPTIMIZER_FIELDS}


def _experiment(t: Table, base_dir: Path) -> Experiment:
    data = t.table("data", ("path", "time_column"))
    outputs = t.tables("outputs", ("variable", "column", "weight"))
    inputs = t.tables("inputs", ("column", "variable"))
    starts = {name: to_number(v, join(t.field("starts"), name)) for name, v in t.mapping("starts").items()}
    return Experiment(
        name=t.required_text("name"),
        role=_choice(t, "role", ROLES) or "fit",
        data=_data(data, base_dir) if data is not None else None,
        outputs=[_output(o) for o in outputs] if outputs is not None else None,
        inputs=[_input(i) for i in inputs] if inputs is not None else None,
        set=_set_values(t, "set"),
        start_time=t.number("start_time"),
        stop_time=t.number("stop_time"),
        validation_stop_time=t.number("validation_stop_time"),
        starts=starts,
    )


def job_table(spec: JobSpec) -> dict[str, Any]:
    """The TOML table of ``spec``, as a job file would hold it (``set_from`` already merged into
    ``set``; paths as the spec holds them, which :func:`load_job` made absolute)."""

    def some(**fields: Any) -> dict[str, Any]:
        return {k: (str(v) if isinstance(v, Path) else v) for k, v in fields.items() if v is not None}

    def data(d: DataRef) -> dict[str, Any]:
        return some(path=d.path, time_column=d.time_column)

    def outputs(items: list[OutputMap]) -> list[dict[str, Any]]:
        return [some(variable=o.variable, column=o.column, weight=o.weight) for o in items]

    def inputs(items: list[InputMap]) -> list[dict[str, Any]]:
        return [some(column=i.column, variable=i.variable) for i in items]

    s, o = spec.simulation, spec.optimizer
    table: dict[str, Any] = {
        "model": some(path=spec.model.path, id=spec.model.id, interface=spec.model.interface),
        "outputs": outputs(spec.outputs),
        "inputs": inputs(spec.inputs),
        "parameters": [
            some(name=p.name, start=p.start, lower=p.lower, upper=p.upper, per_experiment=p.per_experiment,
                 scale=p.scale)
            for p in spec.parameters
        ],
        "effects": [
            some(kind=e.kind, state=e.state, reaction=e.reaction, port=e.port, signal=e.signal, output=e.output,
                 input=e.input,
                 parameters={k: some(start=b.start, lower=b.lower, upper=b.upper) for k, b in e.parameters.items()})
            for e in spec.effects
        ],
        "simulation": some(start_time=s.start_time, stop_time=s.stop_time, tolerance=s.tolerance, solver=s.solver,
                           set=dict(s.set) or None, validation_stop_time=s.validation_stop_time),
        "optimizer": some(**optimizer_table(o)),
        "experiments": [
            some(name=x.name, role=x.role, data=data(x.data) if x.data is not None else None,
                 outputs=outputs(x.outputs) if x.outputs is not None else None,
                 inputs=inputs(x.inputs) if x.inputs is not None else None, set=dict(x.set) or None,
                 start_time=x.start_time, stop_time=x.stop_time, validation_stop_time=x.validation_stop_time,
                 starts=dict(x.starts) or None)
            for x in spec.experiments
        ],
    }
    if spec.data.path is not None:
        table["data"] = data(spec.data)
    if spec.workers is not None:
        table["workers"] = {"count": spec.workers}
    return {k: v for k, v in table.items() if v != []}
