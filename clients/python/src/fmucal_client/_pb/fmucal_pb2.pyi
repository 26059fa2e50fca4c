from google.protobuf.internal import containers as _containers
from google.protobuf.internal import enum_type_wrapper as _enum_type_wrapper
from google.protobuf import descriptor as _descriptor
from google.protobuf import message as _message
from collections.abc import Iterable as _Iterable, Mapping as _Mapping
from typing import ClassVar as _ClassVar, Optional as _Optional, Union as _Union

DESCRIPTOR: _descriptor.FileDescriptor

class JobKind(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = ()
    JOB_KIND_CALIBRATION: _ClassVar[JobKind]
    JOB_KIND_EVALUATE_POINTS: _ClassVar[JobKind]

class JobStatus(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = ()
    JOB_STATUS_UNSPECIFIED: _ClassVar[JobStatus]
    JOB_STATUS_QUEUED: _ClassVar[JobStatus]
    JOB_STATUS_RUNNING: _ClassVar[JobStatus]
    JOB_STATUS_SUCCEEDED: _ClassVar[JobStatus]
    JOB_STATUS_FAILED: _ClassVar[JobStatus]
    JOB_STATUS_CANCELLED: _ClassVar[JobStatus]

class PointStatus(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = ()
    POINT_STATUS_UNSPECIFIED: _ClassVar[PointStatus]
    POINT_STATUS_OK: _ClassVar[PointStatus]
    POINT_STATUS_SIMULATION_FAILED: _ClassVar[PointStatus]
    POINT_STATUS_NOT_EVALUATED: _ClassVar[PointStatus]
JOB_KIND_CALIBRATION: JobKind
JOB_KIND_EVALUATE_POINTS: JobKind
JOB_STATUS_UNSPECIFIED: JobStatus
JOB_STATUS_QUEUED: JobStatus
JOB_STATUS_RUNNING: JobStatus
JOB_STATUS_SUCCEEDED: JobStatus
JOB_STATUS_FAILED: JobStatus
JOB_STATUS_CANCELLED: JobStatus
POINT_STATUS_UNSPECIFIED: PointStatus
POINT_STATUS_OK: PointStatus
POINT_STATUS_SIMULATION_FAILED: PointStatus
POINT_STATUS_NOT_EVALUATED: PointStatus

class UploadModelRequest(_message.Message):
    __slots__ = ("chunk",)
    CHUNK_FIELD_NUMBER: _ClassVar[int]
    chunk: bytes
    def __init__(self, chunk: _Optional[bytes] = ...) -> None: ...

class UploadModelResponse(_message.Message):
    __slots__ = ("model_id", "model_name")
    MODEL_ID_FIELD_NUMBER: _ClassVar[int]
    MODEL_NAME_FIELD_NUMBER: _ClassVar[int]
    model_id: str
    model_name: str
    def __init__(self, model_id: _Optional[str] = ..., model_name: _Optional[str] = ...) -> None: ...

class Column(_message.Message):
    __slots__ = ("name", "values")
    NAME_FIELD_NUMBER: _ClassVar[int]
    VALUES_FIELD_NUMBER: _ClassVar[int]
    name: str
    values: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, name: _Optional[str] = ..., values: _Optional[_Iterable[float]] = ...) -> None: ...

class MeasurementData(_message.Message):
    __slots__ = ("time", "columns")
    TIME_FIELD_NUMBER: _ClassVar[int]
    COLUMNS_FIELD_NUMBER: _ClassVar[int]
    time: _containers.RepeatedScalarFieldContainer[float]
    columns: _containers.RepeatedCompositeFieldContainer[Column]
    def __init__(self, time: _Optional[_Iterable[float]] = ..., columns: _Optional[_Iterable[_Union[Column, _Mapping]]] = ...) -> None: ...

class OutputMap(_message.Message):
    __slots__ = ("variable", "column", "weight")
    VARIABLE_FIELD_NUMBER: _ClassVar[int]
    COLUMN_FIELD_NUMBER: _ClassVar[int]
    WEIGHT_FIELD_NUMBER: _ClassVar[int]
    variable: str
    column: str
    weight: float
    def __init__(self, variable: _Optional[str] = ..., column: _Optional[str] = ..., weight: _Optional[float] = ...) -> None: ...

class InputMap(_message.Message):
    __slots__ = ("column", "variable")
    COLUMN_FIELD_NUMBER: _ClassVar[int]
    VARIABLE_FIELD_NUMBER: _ClassVar[int]
    column: str
    variable: str
    def __init__(self, column: _Optional[str] = ..., variable: _Optional[str] = ...) -> None: ...

class ParameterSpec(_message.Message):
    __slots__ = ("name", "start", "lower", "upper", "per_experiment", "scale")
    NAME_FIELD_NUMBER: _ClassVar[int]
    START_FIELD_NUMBER: _ClassVar[int]
    LOWER_FIELD_NUMBER: _ClassVar[int]
    UPPER_FIELD_NUMBER: _ClassVar[int]
    PER_EXPERIMENT_FIELD_NUMBER: _ClassVar[int]
    SCALE_FIELD_NUMBER: _ClassVar[int]
    name: str
    start: float
    lower: float
    upper: float
    per_experiment: bool
    scale: str
    def __init__(self, name: _Optional[str] = ..., start: _Optional[float] = ..., lower: _Optional[float] = ..., upper: _Optional[float] = ..., per_experiment: _Optional[bool] = ..., scale: _Optional[str] = ...) -> None: ...

class SimulationSpec(_message.Message):
    __slots__ = ("start_time", "stop_time", "tolerance", "solver", "set", "validation_stop_time")
    class SetEntry(_message.Message):
        __slots__ = ("key", "value")
        KEY_FIELD_NUMBER: _ClassVar[int]
        VALUE_FIELD_NUMBER: _ClassVar[int]
        key: str
        value: str
        def __init__(self, key: _Optional[str] = ..., value: _Optional[str] = ...) -> None: ...
    START_TIME_FIELD_NUMBER: _ClassVar[int]
    STOP_TIME_FIELD_NUMBER: _ClassVar[int]
    TOLERANCE_FIELD_NUMBER: _ClassVar[int]
    SOLVER_FIELD_NUMBER: _ClassVar[int]
    SET_FIELD_NUMBER: _ClassVar[int]
    VALIDATION_STOP_TIME_FIELD_NUMBER: _ClassVar[int]
    start_time: float
    stop_time: float
    tolerance: float
    solver: str
    set: _containers.ScalarMap[str, str]
    validation_stop_time: float
    def __init__(self, start_time: _Optional[float] = ..., stop_time: _Optional[float] = ..., tolerance: _Optional[float] = ..., solver: _Optional[str] = ..., set: _Optional[_Mapping[str, str]] = ..., validation_stop_time: _Optional[float] = ...) -> None: ...

class OptimizerSpec(_message.Message):
    __slots__ = ("x_tol", "f_tol", "max_iters", "max_fevals", "seed", "max_time", "default_algorithm", "nelder_mead", "differential_evolution", "genetic", "cma_es", "least_squares", "legacy_algorithm", "legacy_parallel", "legacy_initial_step", "legacy_population", "legacy_weight", "legacy_crossover", "legacy_bits", "legacy_crossover_rate", "legacy_mutation_rate", "legacy_elitism", "legacy_restarts")
    X_TOL_FIELD_NUMBER: _ClassVar[int]
    F_TOL_FIELD_NUMBER: _ClassVar[int]
    MAX_ITERS_FIELD_NUMBER: _ClassVar[int]
    MAX_FEVALS_FIELD_NUMBER: _ClassVar[int]
    SEED_FIELD_NUMBER: _ClassVar[int]
    MAX_TIME_FIELD_NUMBER: _ClassVar[int]
    DEFAULT_ALGORITHM_FIELD_NUMBER: _ClassVar[int]
    NELDER_MEAD_FIELD_NUMBER: _ClassVar[int]
    DIFFERENTIAL_EVOLUTION_FIELD_NUMBER: _ClassVar[int]
    GENETIC_FIELD_NUMBER: _ClassVar[int]
    CMA_ES_FIELD_NUMBER: _ClassVar[int]
    LEAST_SQUARES_FIELD_NUMBER: _ClassVar[int]
    LEGACY_ALGORITHM_FIELD_NUMBER: _ClassVar[int]
    LEGACY_PARALLEL_FIELD_NUMBER: _ClassVar[int]
    LEGACY_INITIAL_STEP_FIELD_NUMBER: _ClassVar[int]
    LEGACY_POPULATION_FIELD_NUMBER: _ClassVar[int]
    LEGACY_WEIGHT_FIELD_NUMBER: _ClassVar[int]
    LEGACY_CROSSOVER_FIELD_NUMBER: _ClassVar[int]
    LEGACY_BITS_FIELD_NUMBER: _ClassVar[int]
    LEGACY_CROSSOVER_RATE_FIELD_NUMBER: _ClassVar[int]
    LEGACY_MUTATION_RATE_FIELD_NUMBER: _ClassVar[int]
    LEGACY_ELITISM_FIELD_NUMBER: _ClassVar[int]
    LEGACY_RESTARTS_FIELD_NUMBER: _ClassVar[int]
    x_tol: float
    f_tol: float
    max_iters: int
    max_fevals: int
    seed: int
    max_time: float
    default_algorithm: NelderMeadOptions
    nelder_mead: NelderMeadOptions
    differential_evolution: DifferentialEvolutionOptions
    genetic: GeneticOptions
    cma_es: CmaEsOptions
    least_squares: LeastSquaresOptions
    legacy_algorithm: str
    legacy_parallel: bool
    legacy_initial_step: float
    legacy_population: int
    legacy_weight: float
    legacy_crossover: float
    legacy_bits: int
    legacy_crossover_rate: float
    legacy_mutation_rate: float
    legacy_elitism: int
    legacy_restarts: int
    def __init__(self, x_tol: _Optional[float] = ..., f_tol: _Optional[float] = ..., max_iters: _Optional[int] = ..., max_fevals: _Optional[int] = ..., seed: _Optional[int] = ..., max_time: _Optional[float] = ..., default_algorithm: _Optional[_Union[NelderMeadOptions, _Mapping]] = ..., nelder_mead: _Optional[_Union[NelderMeadOptions, _Mapping]] = ..., differential_evolution: _Optional[_Union[DifferentialEvolutionOptions, _Mapping]] = ..., genetic: _Optional[_Union[GeneticOptions, _Mapping]] = ..., cma_es: _Optional[_Union[CmaEsOptions, _Mapping]] = ..., least_squares: _Optional[_Union[LeastSquaresOptions, _Mapping]] = ..., legacy_algorithm: _Optional[str] = ..., legacy_parallel: _Optional[bool] = ..., legacy_initial_step: _Optional[float] = ..., legacy_population: _Optional[int] = ..., legacy_weight: _Optional[float] = ..., legacy_crossover: _Optional[float] = ..., legacy_bits: _Optional[int] = ..., legacy_crossover_rate: _Optional[float] = ..., legacy_mutation_rate: _Optional[float] = ..., legacy_elitism: _Optional[int] = ..., legacy_restarts: _Optional[int] = ...) -> None: ...

class NelderMeadOptions(_message.Message):
    __slots__ = ("parallel", "initial_step")
    PARALLEL_FIELD_NUMBER: _ClassVar[int]
    INITIAL_STEP_FIELD_NUMBER: _ClassVar[int]
    parallel: bool
    initial_step: float
    def __init__(self, parallel: _Optional[bool] = ..., initial_step: _Optional[float] = ...) -> None: ...

class DifferentialEvolutionOptions(_message.Message):
    __slots__ = ("population", "weight", "crossover")
    POPULATION_FIELD_NUMBER: _ClassVar[int]
    WEIGHT_FIELD_NUMBER: _ClassVar[int]
    CROSSOVER_FIELD_NUMBER: _ClassVar[int]
    population: int
    weight: float
    crossover: float
    def __init__(self, population: _Optional[int] = ..., weight: _Optional[float] = ..., crossover: _Optional[float] = ...) -> None: ...

class GeneticOptions(_message.Message):
    __slots__ = ("population", "bits", "crossover_rate", "mutation_rate", "elitism")
    POPULATION_FIELD_NUMBER: _ClassVar[int]
    BITS_FIELD_NUMBER: _ClassVar[int]
    CROSSOVER_RATE_FIELD_NUMBER: _ClassVar[int]
    MUTATION_RATE_FIELD_NUMBER: _ClassVar[int]
    ELITISM_FIELD_NUMBER: _ClassVar[int]
    population: int
    bits: int
    crossover_rate: float
    mutation_rate: float
    elitism: int
    def __init__(self, population: _Optional[int] = ..., bits: _Optional[int] = ..., crossover_rate: _Optional[float] = ..., mutation_rate: _Optional[float] = ..., elitism: _Optional[int] = ...) -> None: ...

class CmaEsOptions(_message.Message):
    __slots__ = ("initial_step", "population", "restarts")
    INITIAL_STEP_FIELD_NUMBER: _ClassVar[int]
    POPULATION_FIELD_NUMBER: _ClassVar[int]
    RESTARTS_FIELD_NUMBER: _ClassVar[int]
    initial_step: float
    population: int
    restarts: int
    def __init__(self, initial_step: _Optional[float] = ..., population: _Optional[int] = ..., restarts: _Optional[int] = ...) -> None: ...

class LeastSquaresOptions(_message.Message):
    __slots__ = ("initial_step",)
    INITIAL_STEP_FIELD_NUMBER: _ClassVar[int]
    initial_step: float
    def __init__(self, initial_step: _Optional[float] = ...) -> None: ...

class Point(_message.Message):
    __slots__ = ("x",)
    X_FIELD_NUMBER: _ClassVar[int]
    x: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, x: _Optional[_Iterable[float]] = ...) -> None: ...

class JobSpec(_message.Message):
    __slots__ = ("model_id", "interface", "data", "outputs", "inputs", "parameters", "simulation", "optimizer", "kind", "points", "effects", "experiments")
    MODEL_ID_FIELD_NUMBER: _ClassVar[int]
    INTERFACE_FIELD_NUMBER: _ClassVar[int]
    DATA_FIELD_NUMBER: _ClassVar[int]
    OUTPUTS_FIELD_NUMBER: _ClassVar[int]
    INPUTS_FIELD_NUMBER: _ClassVar[int]
    PARAMETERS_FIELD_NUMBER: _ClassVar[int]
    SIMULATION_FIELD_NUMBER: _ClassVar[int]
    OPTIMIZER_FIELD_NUMBER: _ClassVar[int]
    KIND_FIELD_NUMBER: _ClassVar[int]
    POINTS_FIELD_NUMBER: _ClassVar[int]
    EFFECTS_FIELD_NUMBER: _ClassVar[int]
    EXPERIMENTS_FIELD_NUMBER: _ClassVar[int]
    model_id: str
    interface: str
    data: MeasurementData
    outputs: _containers.RepeatedCompositeFieldContainer[OutputMap]
    inputs: _containers.RepeatedCompositeFieldContainer[InputMap]
    parameters: _containers.RepeatedCompositeFieldContainer[ParameterSpec]
    simulation: SimulationSpec
    optimizer: OptimizerSpec
    kind: JobKind
    points: _containers.RepeatedCompositeFieldContainer[Point]
    effects: _containers.RepeatedCompositeFieldContainer[EffectSpec]
    experiments: _containers.RepeatedCompositeFieldContainer[Experiment]
    def __init__(self, model_id: _Optional[str] = ..., interface: _Optional[str] = ..., data: _Optional[_Union[MeasurementData, _Mapping]] = ..., outputs: _Optional[_Iterable[_Union[OutputMap, _Mapping]]] = ..., inputs: _Optional[_Iterable[_Union[InputMap, _Mapping]]] = ..., parameters: _Optional[_Iterable[_Union[ParameterSpec, _Mapping]]] = ..., simulation: _Optional[_Union[SimulationSpec, _Mapping]] = ..., optimizer: _Optional[_Union[OptimizerSpec, _Mapping]] = ..., kind: _Optional[_Union[JobKind, str]] = ..., points: _Optional[_Iterable[_Union[Point, _Mapping]]] = ..., effects: _Optional[_Iterable[_Union[EffectSpec, _Mapping]]] = ..., experiments: _Optional[_Iterable[_Union[Experiment, _Mapping]]] = ...) -> None: ...

class Experiment(_message.Message):
    __slots__ = ("name", "role", "data", "outputs", "inputs", "set", "start_time", "stop_time", "validation_stop_time", "starts")
    class SetEntry(_message.Message):
        __slots__ = ("key", "value")
        KEY_FIELD_NUMBER: _ClassVar[int]
        VALUE_FIELD_NUMBER: _ClassVar[int]
        key: str
        value: str
        def __init__(self, key: _Optional[str] = ..., value: _Optional[str] = ...) -> None: ...
    class StartsEntry(_message.Message):
        __slots__ = ("key", "value")
        KEY_FIELD_NUMBER: _ClassVar[int]
        VALUE_FIELD_NUMBER: _ClassVar[int]
        key: str
        value: float
        def __init__(self, key: _Optional[str] = ..., value: _Optional[float] = ...) -> None: ...
    NAME_FIELD_NUMBER: _ClassVar[int]
    ROLE_FIELD_NUMBER: _ClassVar[int]
    DATA_FIELD_NUMBER: _ClassVar[int]
    OUTPUTS_FIELD_NUMBER: _ClassVar[int]
    INPUTS_FIELD_NUMBER: _ClassVar[int]
    SET_FIELD_NUMBER: _ClassVar[int]
    START_TIME_FIELD_NUMBER: _ClassVar[int]
    STOP_TIME_FIELD_NUMBER: _ClassVar[int]
    VALIDATION_STOP_TIME_FIELD_NUMBER: _ClassVar[int]
    STARTS_FIELD_NUMBER: _ClassVar[int]
    name: str
    role: str
    data: MeasurementData
    outputs: OutputList
    inputs: InputList
    set: _containers.ScalarMap[str, str]
    start_time: float
    stop_time: float
    validation_stop_time: float
    starts: _containers.ScalarMap[str, float]
    def __init__(self, name: _Optional[str] = ..., role: _Optional[str] = ..., data: _Optional[_Union[MeasurementData, _Mapping]] = ..., outputs: _Optional[_Union[OutputList, _Mapping]] = ..., inputs: _Optional[_Union[InputList, _Mapping]] = ..., set: _Optional[_Mapping[str, str]] = ..., start_time: _Optional[float] = ..., stop_time: _Optional[float] = ..., validation_stop_time: _Optional[float] = ..., starts: _Optional[_Mapping[str, float]] = ...) -> None: ...

class OutputList(_message.Message):
    __slots__ = ("items",)
    ITEMS_FIELD_NUMBER: _ClassVar[int]
    items: _containers.RepeatedCompositeFieldContainer[OutputMap]
    def __init__(self, items: _Optional[_Iterable[_Union[OutputMap, _Mapping]]] = ...) -> None: ...

class InputList(_message.Message):
    __slots__ = ("items",)
    ITEMS_FIELD_NUMBER: _ClassVar[int]
    items: _containers.RepeatedCompositeFieldContainer[InputMap]
    def __init__(self, items: _Optional[_Iterable[_Union[InputMap, _Mapping]]] = ...) -> None: ...

class EffectSpec(_message.Message):
    __slots__ = ("kind", "port", "signal", "output", "input", "parameters", "state", "reaction")
    class ParametersEntry(_message.Message):
        __slots__ = ("key", "value")
        KEY_FIELD_NUMBER: _ClassVar[int]
        VALUE_FIELD_NUMBER: _ClassVar[int]
        key: str
        value: Bounds
        def __init__(self, key: _Optional[str] = ..., value: _Optional[_Union[Bounds, _Mapping]] = ...) -> None: ...
    KIND_FIELD_NUMBER: _ClassVar[int]
    PORT_FIELD_NUMBER: _ClassVar[int]
    SIGNAL_FIELD_NUMBER: _ClassVar[int]
    OUTPUT_FIELD_NUMBER: _ClassVar[int]
    INPUT_FIELD_NUMBER: _ClassVar[int]
    PARAMETERS_FIELD_NUMBER: _ClassVar[int]
    STATE_FIELD_NUMBER: _ClassVar[int]
    REACTION_FIELD_NUMBER: _ClassVar[int]
    kind: str
    port: str
    signal: str
    output: str
    input: str
    parameters: _containers.MessageMap[str, Bounds]
    state: str
    reaction: str
    def __init__(self, kind: _Optional[str] = ..., port: _Optional[str] = ..., signal: _Optional[str] = ..., output: _Optional[str] = ..., input: _Optional[str] = ..., parameters: _Optional[_Mapping[str, Bounds]] = ..., state: _Optional[str] = ..., reaction: _Optional[str] = ...) -> None: ...

class Bounds(_message.Message):
    __slots__ = ("start", "lower", "upper")
    START_FIELD_NUMBER: _ClassVar[int]
    LOWER_FIELD_NUMBER: _ClassVar[int]
    UPPER_FIELD_NUMBER: _ClassVar[int]
    start: float
    lower: float
    upper: float
    def __init__(self, start: _Optional[float] = ..., lower: _Optional[float] = ..., upper: _Optional[float] = ...) -> None: ...

class SubmitJobRequest(_message.Message):
    __slots__ = ("spec",)
    SPEC_FIELD_NUMBER: _ClassVar[int]
    spec: JobSpec
    def __init__(self, spec: _Optional[_Union[JobSpec, _Mapping]] = ...) -> None: ...

class SubmitJobResponse(_message.Message):
    __slots__ = ("job_id",)
    JOB_ID_FIELD_NUMBER: _ClassVar[int]
    job_id: str
    def __init__(self, job_id: _Optional[str] = ...) -> None: ...

class WatchJobRequest(_message.Message):
    __slots__ = ("job_id",)
    JOB_ID_FIELD_NUMBER: _ClassVar[int]
    job_id: str
    def __init__(self, job_id: _Optional[str] = ...) -> None: ...

class WatchJobResponse(_message.Message):
    __slots__ = ("iteration", "evaluations", "best_f", "best_x", "batch_wall_s", "status", "rounds")
    ITERATION_FIELD_NUMBER: _ClassVar[int]
    EVALUATIONS_FIELD_NUMBER: _ClassVar[int]
    BEST_F_FIELD_NUMBER: _ClassVar[int]
    BEST_X_FIELD_NUMBER: _ClassVar[int]
    BATCH_WALL_S_FIELD_NUMBER: _ClassVar[int]
    STATUS_FIELD_NUMBER: _ClassVar[int]
    ROUNDS_FIELD_NUMBER: _ClassVar[int]
    iteration: int
    evaluations: int
    best_f: float
    best_x: _containers.RepeatedScalarFieldContainer[float]
    batch_wall_s: float
    status: JobStatus
    rounds: int
    def __init__(self, iteration: _Optional[int] = ..., evaluations: _Optional[int] = ..., best_f: _Optional[float] = ..., best_x: _Optional[_Iterable[float]] = ..., batch_wall_s: _Optional[float] = ..., status: _Optional[_Union[JobStatus, str]] = ..., rounds: _Optional[int] = ...) -> None: ...

class GetJobRequest(_message.Message):
    __slots__ = ("job_id",)
    JOB_ID_FIELD_NUMBER: _ClassVar[int]
    job_id: str
    def __init__(self, job_id: _Optional[str] = ...) -> None: ...

class JobResult(_message.Message):
    __slots__ = ("names", "x_opt", "f_opt", "iterations", "evaluations", "elapsed_s", "termination", "failed_evaluations", "rounds", "evaluated", "warnings")
    NAMES_FIELD_NUMBER: _ClassVar[int]
    X_OPT_FIELD_NUMBER: _ClassVar[int]
    F_OPT_FIELD_NUMBER: _ClassVar[int]
    ITERATIONS_FIELD_NUMBER: _ClassVar[int]
    EVALUATIONS_FIELD_NUMBER: _ClassVar[int]
    ELAPSED_S_FIELD_NUMBER: _ClassVar[int]
    TERMINATION_FIELD_NUMBER: _ClassVar[int]
    FAILED_EVALUATIONS_FIELD_NUMBER: _ClassVar[int]
    ROUNDS_FIELD_NUMBER: _ClassVar[int]
    EVALUATED_FIELD_NUMBER: _ClassVar[int]
    WARNINGS_FIELD_NUMBER: _ClassVar[int]
    names: _containers.RepeatedScalarFieldContainer[str]
    x_opt: _containers.RepeatedScalarFieldContainer[float]
    f_opt: float
    iterations: int
    evaluations: int
    elapsed_s: float
    termination: str
    failed_evaluations: int
    rounds: int
    evaluated: _containers.RepeatedCompositeFieldContainer[EvaluatedPoint]
    warnings: _containers.RepeatedScalarFieldContainer[str]
    def __init__(self, names: _Optional[_Iterable[str]] = ..., x_opt: _Optional[_Iterable[float]] = ..., f_opt: _Optional[float] = ..., iterations: _Optional[int] = ..., evaluations: _Optional[int] = ..., elapsed_s: _Optional[float] = ..., termination: _Optional[str] = ..., failed_evaluations: _Optional[int] = ..., rounds: _Optional[int] = ..., evaluated: _Optional[_Iterable[_Union[EvaluatedPoint, _Mapping]]] = ..., warnings: _Optional[_Iterable[str]] = ...) -> None: ...

class EvaluatedPoint(_message.Message):
    __slots__ = ("x", "ok", "value", "residuals", "message")
    X_FIELD_NUMBER: _ClassVar[int]
    OK_FIELD_NUMBER: _ClassVar[int]
    VALUE_FIELD_NUMBER: _ClassVar[int]
    RESIDUALS_FIELD_NUMBER: _ClassVar[int]
    MESSAGE_FIELD_NUMBER: _ClassVar[int]
    x: _containers.RepeatedScalarFieldContainer[float]
    ok: bool
    value: float
    residuals: _containers.RepeatedScalarFieldContainer[float]
    message: str
    def __init__(self, x: _Optional[_Iterable[float]] = ..., ok: _Optional[bool] = ..., value: _Optional[float] = ..., residuals: _Optional[_Iterable[float]] = ..., message: _Optional[str] = ...) -> None: ...

class GetJobResponse(_message.Message):
    __slots__ = ("job_id", "status", "result", "error")
    JOB_ID_FIELD_NUMBER: _ClassVar[int]
    STATUS_FIELD_NUMBER: _ClassVar[int]
    RESULT_FIELD_NUMBER: _ClassVar[int]
    ERROR_FIELD_NUMBER: _ClassVar[int]
    job_id: str
    status: JobStatus
    result: JobResult
    error: str
    def __init__(self, job_id: _Optional[str] = ..., status: _Optional[_Union[JobStatus, str]] = ..., result: _Optional[_Union[JobResult, _Mapping]] = ..., error: _Optional[str] = ...) -> None: ...

class CancelJobRequest(_message.Message):
    __slots__ = ("job_id",)
    JOB_ID_FIELD_NUMBER: _ClassVar[int]
    job_id: str
    def __init__(self, job_id: _Optional[str] = ...) -> None: ...

class CancelJobResponse(_message.Message):
    __slots__ = ("status",)
    STATUS_FIELD_NUMBER: _ClassVar[int]
    status: JobStatus
    def __init__(self, status: _Optional[_Union[JobStatus, str]] = ...) -> None: ...

class ListJobsRequest(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class JobSummary(_message.Message):
    __slots__ = ("job_id", "status", "best_f", "evaluations")
    JOB_ID_FIELD_NUMBER: _ClassVar[int]
    STATUS_FIELD_NUMBER: _ClassVar[int]
    BEST_F_FIELD_NUMBER: _ClassVar[int]
    EVALUATIONS_FIELD_NUMBER: _ClassVar[int]
    job_id: str
    status: JobStatus
    best_f: float
    evaluations: int
    def __init__(self, job_id: _Optional[str] = ..., status: _Optional[_Union[JobStatus, str]] = ..., best_f: _Optional[float] = ..., evaluations: _Optional[int] = ...) -> None: ...

class ListJobsResponse(_message.Message):
    __slots__ = ("jobs",)
    JOBS_FIELD_NUMBER: _ClassVar[int]
    jobs: _containers.RepeatedCompositeFieldContainer[JobSummary]
    def __init__(self, jobs: _Optional[_Iterable[_Union[JobSummary, _Mapping]]] = ...) -> None: ...

class DeleteJobRequest(_message.Message):
    __slots__ = ("job_id",)
    JOB_ID_FIELD_NUMBER: _ClassVar[int]
    job_id: str
    def __init__(self, job_id: _Optional[str] = ...) -> None: ...

class DeleteJobResponse(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class DiagnoseRequest(_message.Message):
    __slots__ = ("spec", "settings")
    SPEC_FIELD_NUMBER: _ClassVar[int]
    SETTINGS_FIELD_NUMBER: _ClassVar[int]
    spec: JobSpec
    settings: DiagnoseSettings
    def __init__(self, spec: _Optional[_Union[JobSpec, _Mapping]] = ..., settings: _Optional[_Union[DiagnoseSettings, _Mapping]] = ...) -> None: ...

class DiagnoseSettings(_message.Message):
    __slots__ = ("ports", "signals", "top", "fix_base", "holdout", "min_validation_gain", "confidence", "windows", "rounds", "series", "states", "states_given", "exclude")
    PORTS_FIELD_NUMBER: _ClassVar[int]
    SIGNALS_FIELD_NUMBER: _ClassVar[int]
    TOP_FIELD_NUMBER: _ClassVar[int]
    FIX_BASE_FIELD_NUMBER: _ClassVar[int]
    HOLDOUT_FIELD_NUMBER: _ClassVar[int]
    MIN_VALIDATION_GAIN_FIELD_NUMBER: _ClassVar[int]
    CONFIDENCE_FIELD_NUMBER: _ClassVar[int]
    WINDOWS_FIELD_NUMBER: _ClassVar[int]
    ROUNDS_FIELD_NUMBER: _ClassVar[int]
    SERIES_FIELD_NUMBER: _ClassVar[int]
    STATES_FIELD_NUMBER: _ClassVar[int]
    STATES_GIVEN_FIELD_NUMBER: _ClassVar[int]
    EXCLUDE_FIELD_NUMBER: _ClassVar[int]
    ports: _containers.RepeatedCompositeFieldContainer[DiagnosePort]
    signals: _containers.RepeatedScalarFieldContainer[str]
    top: int
    fix_base: bool
    holdout: float
    min_validation_gain: float
    confidence: float
    windows: int
    rounds: int
    series: bool
    states: _containers.RepeatedScalarFieldContainer[str]
    states_given: bool
    exclude: _containers.RepeatedScalarFieldContainer[str]
    def __init__(self, ports: _Optional[_Iterable[_Union[DiagnosePort, _Mapping]]] = ..., signals: _Optional[_Iterable[str]] = ..., top: _Optional[int] = ..., fix_base: _Optional[bool] = ..., holdout: _Optional[float] = ..., min_validation_gain: _Optional[float] = ..., confidence: _Optional[float] = ..., windows: _Optional[int] = ..., rounds: _Optional[int] = ..., series: _Optional[bool] = ..., states: _Optional[_Iterable[str]] = ..., states_given: _Optional[bool] = ..., exclude: _Optional[_Iterable[str]] = ...) -> None: ...

class DiagnosePort(_message.Message):
    __slots__ = ("port", "domain", "velocities", "positions", "temperatures", "scale", "ambient")
    PORT_FIELD_NUMBER: _ClassVar[int]
    DOMAIN_FIELD_NUMBER: _ClassVar[int]
    VELOCITIES_FIELD_NUMBER: _ClassVar[int]
    POSITIONS_FIELD_NUMBER: _ClassVar[int]
    TEMPERATURES_FIELD_NUMBER: _ClassVar[int]
    SCALE_FIELD_NUMBER: _ClassVar[int]
    AMBIENT_FIELD_NUMBER: _ClassVar[int]
    port: str
    domain: str
    velocities: _containers.RepeatedScalarFieldContainer[str]
    positions: _containers.RepeatedScalarFieldContainer[str]
    temperatures: _containers.RepeatedScalarFieldContainer[str]
    scale: float
    ambient: float
    def __init__(self, port: _Optional[str] = ..., domain: _Optional[str] = ..., velocities: _Optional[_Iterable[str]] = ..., positions: _Optional[_Iterable[str]] = ..., temperatures: _Optional[_Iterable[str]] = ..., scale: _Optional[float] = ..., ambient: _Optional[float] = ...) -> None: ...

class DiagnoseResponse(_message.Message):
    __slots__ = ("progress", "result")
    PROGRESS_FIELD_NUMBER: _ClassVar[int]
    RESULT_FIELD_NUMBER: _ClassVar[int]
    progress: str
    result: DiagnoseResult
    def __init__(self, progress: _Optional[str] = ..., result: _Optional[_Union[DiagnoseResult, _Mapping]] = ...) -> None: ...

class DiagnoseResult(_message.Message):
    __slots__ = ("summary", "named", "effects", "report_json")
    SUMMARY_FIELD_NUMBER: _ClassVar[int]
    NAMED_FIELD_NUMBER: _ClassVar[int]
    EFFECTS_FIELD_NUMBER: _ClassVar[int]
    REPORT_JSON_FIELD_NUMBER: _ClassVar[int]
    summary: str
    named: _containers.RepeatedScalarFieldContainer[str]
    effects: _containers.RepeatedCompositeFieldContainer[EffectSpec]
    report_json: str
    def __init__(self, summary: _Optional[str] = ..., named: _Optional[_Iterable[str]] = ..., effects: _Optional[_Iterable[_Union[EffectSpec, _Mapping]]] = ..., report_json: _Optional[str] = ...) -> None: ...

class RegisterRequest(_message.Message):
    __slots__ = ("protocol_version", "slots", "name")
    PROTOCOL_VERSION_FIELD_NUMBER: _ClassVar[int]
    SLOTS_FIELD_NUMBER: _ClassVar[int]
    NAME_FIELD_NUMBER: _ClassVar[int]
    protocol_version: int
    slots: int
    name: str
    def __init__(self, protocol_version: _Optional[int] = ..., slots: _Optional[int] = ..., name: _Optional[str] = ...) -> None: ...

class RegisterResponse(_message.Message):
    __slots__ = ("worker_id", "heartbeat_interval_ms", "evaluation_timeout_ms")
    WORKER_ID_FIELD_NUMBER: _ClassVar[int]
    HEARTBEAT_INTERVAL_MS_FIELD_NUMBER: _ClassVar[int]
    EVALUATION_TIMEOUT_MS_FIELD_NUMBER: _ClassVar[int]
    worker_id: str
    heartbeat_interval_ms: int
    evaluation_timeout_ms: int
    def __init__(self, worker_id: _Optional[str] = ..., heartbeat_interval_ms: _Optional[int] = ..., evaluation_timeout_ms: _Optional[int] = ...) -> None: ...

class HeartbeatRequest(_message.Message):
    __slots__ = ("worker_id",)
    WORKER_ID_FIELD_NUMBER: _ClassVar[int]
    worker_id: str
    def __init__(self, worker_id: _Optional[str] = ...) -> None: ...

class HeartbeatResponse(_message.Message):
    __slots__ = ("known",)
    KNOWN_FIELD_NUMBER: _ClassVar[int]
    known: bool
    def __init__(self, known: _Optional[bool] = ...) -> None: ...

class FetchModelRequest(_message.Message):
    __slots__ = ("model_id",)
    MODEL_ID_FIELD_NUMBER: _ClassVar[int]
    model_id: str
    def __init__(self, model_id: _Optional[str] = ...) -> None: ...

class FetchModelResponse(_message.Message):
    __slots__ = ("chunk",)
    CHUNK_FIELD_NUMBER: _ClassVar[int]
    chunk: bytes
    def __init__(self, chunk: _Optional[bytes] = ...) -> None: ...

class FetchJobRequest(_message.Message):
    __slots__ = ("job_id",)
    JOB_ID_FIELD_NUMBER: _ClassVar[int]
    job_id: str
    def __init__(self, job_id: _Optional[str] = ...) -> None: ...

class FetchJobResponse(_message.Message):
    __slots__ = ("spec",)
    SPEC_FIELD_NUMBER: _ClassVar[int]
    spec: JobSpec
    def __init__(self, spec: _Optional[_Union[JobSpec, _Mapping]] = ...) -> None: ...

class Assignment(_message.Message):
    __slots__ = ("job_id", "point_id", "x", "want_residuals", "experiment")
    JOB_ID_FIELD_NUMBER: _ClassVar[int]
    POINT_ID_FIELD_NUMBER: _ClassVar[int]
    X_FIELD_NUMBER: _ClassVar[int]
    WANT_RESIDUALS_FIELD_NUMBER: _ClassVar[int]
    EXPERIMENT_FIELD_NUMBER: _ClassVar[int]
    job_id: str
    point_id: int
    x: _containers.RepeatedScalarFieldContainer[float]
    want_residuals: bool
    experiment: int
    def __init__(self, job_id: _Optional[str] = ..., point_id: _Optional[int] = ..., x: _Optional[_Iterable[float]] = ..., want_residuals: _Optional[bool] = ..., experiment: _Optional[int] = ...) -> None: ...

class PointResult(_message.Message):
    __slots__ = ("job_id", "point_id", "status", "value", "message", "wall_s", "residuals")
    JOB_ID_FIELD_NUMBER: _ClassVar[int]
    POINT_ID_FIELD_NUMBER: _ClassVar[int]
    STATUS_FIELD_NUMBER: _ClassVar[int]
    VALUE_FIELD_NUMBER: _ClassVar[int]
    MESSAGE_FIELD_NUMBER: _ClassVar[int]
    WALL_S_FIELD_NUMBER: _ClassVar[int]
    RESIDUALS_FIELD_NUMBER: _ClassVar[int]
    job_id: str
    point_id: int
    status: PointStatus
    value: float
    message: str
    wall_s: float
    residuals: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, job_id: _Optional[str] = ..., point_id: _Optional[int] = ..., status: _Optional[_Union[PointStatus, str]] = ..., value: _Optional[float] = ..., message: _Optional[str] = ..., wall_s: _Optional[float] = ..., residuals: _Optional[_Iterable[float]] = ...) -> None: ...

class PollWorkRequest(_message.Message):
    __slots__ = ("worker_id", "results", "max_points", "wait_ms")
    WORKER_ID_FIELD_NUMBER: _ClassVar[int]
    RESULTS_FIELD_NUMBER: _ClassVar[int]
    MAX_POINTS_FIELD_NUMBER: _ClassVar[int]
    WAIT_MS_FIELD_NUMBER: _ClassVar[int]
    worker_id: str
    results: _containers.RepeatedCompositeFieldContainer[PointResult]
    max_points: int
    wait_ms: int
    def __init__(self, worker_id: _Optional[str] = ..., results: _Optional[_Iterable[_Union[PointResult, _Mapping]]] = ..., max_points: _Optional[int] = ..., wait_ms: _Optional[int] = ...) -> None: ...

class PollWorkResponse(_message.Message):
    __slots__ = ("assignments", "known")
    ASSIGNMENTS_FIELD_NUMBER: _ClassVar[int]
    KNOWN_FIELD_NUMBER: _ClassVar[int]
    assignments: _containers.RepeatedCompositeFieldContainer[Assignment]
    known: bool
    def __init__(self, assignments: _Optional[_Iterable[_Union[Assignment, _Mapping]]] = ..., known: _Optional[bool] = ...) -> None: ...
