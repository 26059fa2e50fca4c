"""The exceptions of fmucal_client: one hierarchy under :class:`FmucalError`.

- :class:`JobFileError`: the job (a TOML file or a dict) or its data cannot be read; ``field``
  names the culprit as the CLI does (``parameters[1].lower``, ``experiments[0].data``).
- :class:`ConfigurationError`: the client's own settings (URL, token, TLS files).
- :class:`ServerError` and its subclasses: a gRPC call failed; ``code`` is the status code,
  ``details`` the coordinator's message (which names the field of a refused job) and ``field``
  that field, when the message starts with one.
- :class:`JobFailedError`: a job ended in the failed state.
- :class:`CommandError`: a local run of the ``fmucal`` binary failed; ``field`` names the job's
  field its ``error:`` line starts with.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

import grpc

if TYPE_CHECKING:
    from .results import JobResult


class FmucalError(Exception):
    """Every error this package raises."""


class ConfigurationError(FmucalError):
    """A client setting cannot be used: a malformed URL, an unreadable token or TLS file."""


class JobFileError(FmucalError):
    """A job that cannot be read: ``field`` names where, ``message`` says what is wrong."""

    def __init__(self, field: str, message: str) -> None:
        super().__init__(f"{field}: {message}")
        self.field = field
        self.message = message


class ServerError(FmucalError):
    """A gRPC call the coordinator answered with an error (or that could not reach it)."""

    def __init__(self, code: grpc.StatusCode, details: str) -> None:
        super().__init__(f"{code.name}: {details}")
        self.code = code
        self.details = details
        self.field = field_of(details) if code in _NAMES_FIELDS else None


class InvalidArgumentError(ServerError):
    """INVALID_ARGUMENT: the coordinator refused the request; ``field`` names the culprit."""


class NotFoundError(ServerError):
    """NOT_FOUND: no such job (or model)."""


class AuthenticationError(ServerError):
    """UNAUTHENTICATED or PERMISSION_DENIED: a missing or wrong token."""


class ResourceExhaustedError(ServerError):
    """RESOURCE_EXHAUSTED: a request past one of the coordinator's caps."""


class FailedPreconditionError(ServerError):
    """FAILED_PRECONDITION: e.g. deleting a job that is still running."""


class UnavailableError(ServerError):
    """UNAVAILABLE or DEADLINE_EXCEEDED: the coordinator cannot be reached."""


class JobFailedError(FmucalError):
    """A job ended FAILED; ``result`` holds its best point so far (or its start point)."""

    def __init__(self, job_id: str, message: str, result: JobResult) -> None:
        super().__init__(f"job {job_id} failed: {message}")
        self.job_id = job_id
        self.message = message
        self.result = result


_CLASSES: dict[grpc.StatusCode, type[ServerError]] = {
    grpc.StatusCode.INVALID_ARGUMENT: InvalidArgumentError,
    grpc.StatusCode.NOT_FOUND: NotFoundError,
    grpc.StatusCode.UNAUTHENTICATED: AuthenticationError,
    grpc.StatusCode.PERMISSION_DENIED: AuthenticationError,
    grpc.StatusCode.RESOURCE_EXHAUSTED: ResourceExhaustedError,
    grpc.StatusCode.FAILED_PRECONDITION: FailedPreconditionError,
    grpc.StatusCode.UNAVAILABLE: UnavailableError,
    grpc.StatusCode.DEADLINE_EXCEEDED: UnavailableError,
}

# Codes whose messages start with the field at fault ("parameters[0].lower: ...").
_NAMES_FIELDS = {grpc.StatusCode.INVALID_ARGUMENT, grpc.StatusCode.RESOURCE_EXHAUSTED}

# A field path as the coordinator writes it: dotted names with [index] or [name] parts.
_FIELD = re.compile(r"^([A-Za-z_][\w@-]*(?:\[[^\]\s]*\])*(?:\.[A-Za-z_][\w@-]*(?:\[[^\]\s]*\])*)*): ")


def field_of(message: str) -> str | None:
    """The field a coordinator message starts with (``"outputs[0].variable: ..."``), if any."""
    match = _FIELD.match(message)
    return match.group(1) if match else None


def from_rpc_error(error: grpc.RpcError) -> ServerError:
    """The exception for a failed gRPC call, of the class its status code maps to."""
    code = error.code() if isinstance(error, grpc.Call) else grpc.StatusCode.UNKNOWN
    details = (error.details() if isinstance(error, grpc.Call) else None) or str(error)
    return _CLASSES.get(code, ServerError)(code, details)


class CommandError(FmucalError):
    """A local run of the ``fmucal`` binary failed. ``message`` is its one-line ``error: ...``
    (without the prefix), ``field`` the job field it starts with, if any
    (``parameters[0].lower``), ``exit_code`` its exit status and ``stderr`` all it wrote there."""

    def __init__(
        self, message: str, *, exit_code: int | None = None, stderr: str = "", command: list[str] | None = None
    ) -> None:
        super().__init__(message)
        self.message = message
        self.field = field_of(message)
        self.exit_code = exit_code
        self.stderr = stderr
        self.command = command or []

    @classmethod
    def from_stderr(cls, stderr: str, exit_code: int, command: list[str]) -> CommandError:
        """The error of a run that exited with ``exit_code``: its last ``error:`` line (a TOML
        syntax error's following lines, which show where, included), else its last line."""
        lines = stderr.rstrip("\n").splitlines()
        starts = [i for i, line in enumerate(lines) if line.startswith("error: ")]
        if starts:
            message = "\n".join(lines[starts[-1]:]).removeprefix("error: ")
        elif exit_code < 0:
            message = f"fmucal was killed by signal {-exit_code}"
        else:
            message = (lines[-1] if lines else "") or f"fmucal exited with status {exit_code}"
        return cls(message, exit_code=exit_code, stderr=stderr, command=command)
