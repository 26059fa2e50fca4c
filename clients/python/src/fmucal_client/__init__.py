"""fmucal_client: calibrate FMU parameters from Python.

>>> import fmucal_client as fmucal
>>> result = fmucal.calibrate("examples/furuta/job.toml")   # local worker processes
>>> result.x_opt                                            # {'armFriction': 0.00999..., ...}
>>> result.standard_errors, result.rms, result.fit_percent
>>> result.plot()                                           # with matplotlib installed

:func:`calibrate`, :func:`diagnose` and :func:`simulate` run the ``fmucal`` binary the package
installed; ``coordinator=URL`` runs a calibration on a coordinator's pool instead, through the
gRPC client:

>>> from fmucal_client import Client
>>> with Client("http://127.0.0.1:50051") as c:          # token from FMUCAL_TOKEN
...     job_id = c.submit("examples/furuta/job.toml")     # uploads the model, sends the data
...     for event in c.watch(job_id):                     # progress, one event per batch
...         print(event.rounds, event.best_f)
...     print(c.result(job_id).x_opt)                     # {'armFriction': 0.00999..., ...}

The job is a TOML job file as the CLI reads it, or a dict of the same structure; errors are
:class:`FmucalError` subclasses naming the field at fault.
"""

from .api import calibrate, diagnose, simulate
from .calibration import (
    CalibrationResult,
    Diagnosis,
    Errors,
    Estimate,
    FitTable,
    OutputError,
    Series,
    SimulationResult,
    WindowError,
)
from .client import Client, build_request
from .errors import (
    AuthenticationError,
    CommandError,
    ConfigurationError,
    FailedPreconditionError,
    FmucalError,
    InvalidArgumentError,
    JobFailedError,
    JobFileError,
    NotFoundError,
    ResourceExhaustedError,
    ServerError,
    UnavailableError,
)
from .job import JobSpec, load_job
from .results import EvaluatedPoint, JobResult, Progress

__all__ = [
    "AuthenticationError",
    "CalibrationResult",
    "Client",
    "CommandError",
    "ConfigurationError",
    "Diagnosis",
    "Errors",
    "Estimate",
    "FitTable",
    "OutputError",
    "Series",
    "SimulationResult",
    "WindowError",
    "EvaluatedPoint",
    "FailedPreconditionError",
    "FmucalError",
    "InvalidArgumentError",
    "JobFailedError",
    "JobFileError",
    "JobResult",
    "JobSpec",
    "NotFoundError",
    "Progress",
    "ResourceExhaustedError",
    "ServerError",
    "UnavailableError",
    "build_request",
    "calibrate",
    "diagnose",
    "load_job",
    "simulate",
]
