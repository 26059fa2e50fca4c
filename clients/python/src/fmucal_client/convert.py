"""A job as the ``SubmitJobRequest`` the CLI sends: the same message, field for field, as the
Rust conversion ``fmucal_proto::convert::job_to_proto`` makes of the same job file.

As there: the simulation and optimizer settings are always present; an output's weight is
always written (1 when the file leaves it out); an experiment's ``outputs``/``inputs`` are
present exactly when the experiment sets them (an empty list too); its ``data`` is present when
it names its own file, and the job's shared table travels once, as ``JobSpec.data``, when some
experiment uses it. Fixed values (``set``) travel as text: numbers as Rust prints them
(:func:`float_text`: shortest round-trip digits, no exponent), ``true``/``false``, and text as
written.

A double without presence (a parameter's start and bounds, an effect's bounds, an experiment's
``starts``) carries no zero on the wire: Rust's encoder leaves out -0.0 as it leaves out 0.0, so
the coordinator reads 0.0. Python's would send -0.0; :func:`_plain` sends what the CLI sends.
"""

from __future__ import annotations

import math
from dataclasses import fields
from decimal import Decimal

from .job import SHARED_SETTINGS, Experiment, InputMap, JobSpec, Optimizer, OutputMap, SetValue
from .proto import pb
from .tables import Table


def float_text(value: float) -> str:
    """``value`` as Rust's ``Display`` prints an f64: ``1`` for 1.0, ``0.0000001`` for 1e-7,
    ``-0`` for -0.0, ``NaN``, ``inf``."""
    if math.isnan(value):
        return "NaN"
    if math.isinf(value):
        return "inf" if value > 0 else "-inf"
    text = format(Decimal(repr(value)), "f")
    return text.rstrip("0").rstrip(".") if "." in text else text


def _plain(value: float) -> float:
    """A double for a field without presence: -0.0 as 0.0, which is what arrives from the CLI."""
    return 0.0 if value == 0.0 else value


def set_text(value: SetValue) -> str:
    """A fixed value as the protocol carries it."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return float_text(value)
    return value


def data_message(table: Table) -> pb.MeasurementData:
    """A measurement table as a message."""
    return pb.MeasurementData(
        time=table.time,
        columns=[pb.Column(name=name, values=values) for name, values in table.columns],
    )


def _output(o: OutputMap) -> pb.OutputMap:
    return pb.OutputMap(variable=o.variable, column=o.column, weight=o.weight)


def _input(i: InputMap) -> pb.InputMap:
    return pb.InputMap(column=i.column, variable=i.variable)


def _experiment(e: Experiment, table: Table) -> pb.Experiment:
    m = pb.Experiment(
        name=e.name,
        role=e.role,
        set={k: set_text(v) for k, v in e.set.items()},
        start_time=e.start_time,
        stop_time=e.stop_time,
        validation_stop_time=e.validation_stop_time,
        starts={k: _plain(v) for k, v in e.starts.items()},
    )
    if e.data is not None:
        m.data.CopyFrom(data_message(table))
    if e.outputs is not None:
        m.outputs.SetInParent()
        m.outputs.items.extend(_output(o) for o in e.outputs)
    if e.inputs is not None:
        m.inputs.SetInParent()
        m.inputs.items.extend(_input(i) for i in e.inputs)
    return m


# The ``OptimizerSpec.algorithm`` member and options message of each algorithm.
_ALGORITHM_MESSAGES = {
    "nelder-mead": ("nelder_mead", pb.NelderMeadOptions),
    "differential-evolution": ("differential_evolution", pb.DifferentialEvolutionOptions),
    "genetic": ("genetic", pb.GeneticOptions),
    "cma-es": ("cma_es", pb.CmaEsOptions),
    "least-squares": ("least_squares", pb.LeastSquaresOptions),
}


def optimizer_message(o: Optimizer) -> pb.OptimizerSpec:
    """The optimizer settings as the protocol carries them: the shared settings, and the
    ``algorithm`` member with its options (``default_algorithm`` when the job names none; the
    ``legacy_*`` fields of protocol version 3 stay unset)."""
    member, options_type = _ALGORITHM_MESSAGES[o.algorithm or "nelder-mead"]
    if o.algorithm is None:
        member = "default_algorithm"
    options = options_type(**{f.name: getattr(o.options, f.name) for f in fields(o.options)})
    return pb.OptimizerSpec(**{name: getattr(o, name) for name in SHARED_SETTINGS}, **{member: options})


def job_message(spec: JobSpec, tables: list[Table], model_id: str) -> pb.JobSpec:
    """The protocol's form of ``spec``; ``tables[k]`` is the table of experiment ``k`` (one
    table for a job without experiments), as :func:`fmucal_client.tables.read_all` gives them."""
    if spec.experiments:
        shared = next((t for e, t in zip(spec.experiments, tables) if e.data is None), None)
    else:
        shared = tables[0] if tables else None
    s, o = spec.simulation, spec.optimizer
    m = pb.JobSpec(
        model_id=model_id,
        interface=spec.model.interface or "",
        outputs=[_output(x) for x in spec.outputs],
        inputs=[_input(x) for x in spec.inputs],
        parameters=[
            pb.ParameterSpec(name=p.name, start=_plain(p.start), lower=_plain(p.lower), upper=_plain(p.upper),
                             per_experiment=p.per_experiment, scale=p.scale)
            for p in spec.parameters
        ],
        simulation=pb.SimulationSpec(
            start_time=s.start_time,
            stop_time=s.stop_time,
            tolerance=s.tolerance,
            solver=s.solver,
            set={k: set_text(v) for k, v in s.set.items()},
            validation_stop_time=s.validation_stop_time,
        ),
        optimizer=optimizer_message(o),
        kind=pb.JOB_KIND_CALIBRATION,
        effects=[
            pb.EffectSpec(
                kind=e.kind, state=e.state, reaction=e.reaction, port=e.port, signal=e.signal, output=e.output,
                input=e.input,
                parameters={
                    n: pb.Bounds(start=_plain(b.start), lower=_plain(b.lower), upper=_plain(b.upper))
                    for n, b in e.parameters.items()
                },
            )
            for e in spec.effects
        ],
        experiments=[_experiment(e, t) for e, t in zip(spec.experiments, tables)],
    )
    # Always present, as the Rust conversion writes them, even when every setting is unset.
    m.simulation.SetInParent()
    m.optimizer.SetInParent()
    if shared is not None:
        m.data.CopyFrom(data_message(shared))
    return m


def submit_request(spec: JobSpec, tables: list[Table], model_id: str) -> pb.SubmitJobRequest:
    """The ``SubmitJobRequest`` of ``spec``."""
    return pb.SubmitJobRequest(spec=job_message(spec, tables, model_id))
