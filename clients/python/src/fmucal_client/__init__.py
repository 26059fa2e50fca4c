"""fmucal_client: the Python client of an fmucal coordinator.

>>> from fmucal_client import Client
>>> with Client("http://127.0.0.1:50051") as c:          # token from FMUCAL_TOKEN
...     job_id = c.submit("examples/furuta/job.toml")     # uploads the model, sends the data
...     for event in c.watch(job_id):                     # progress, one event per batch
...         print(event.rounds, event.best_f)
...     print(c.result(job_id).x_opt)                     # {'armFriction': 0.00999..., ...}

The job is a TOML job file as the CLI reads it, or a dict of the same structure; errors are
:class:`FmucalError` subclasses naming the field at fault.
"""

from .client import Client, build_request
from .errors import (
    AuthenticationError,
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
    "Client",
    "ConfigurationError",
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
    "load_job",
]
