"""The client of a coordinator's ``Calibration`` service: upload a model, submit a job (a TOML job
file or a dict of the same structure), watch its progress, wait for its result, cancel it.

Every call carries the token and maps a failed gRPC call to an exception of
:mod:`fmucal_client.errors` (INVALID_ARGUMENT to :class:`InvalidArgumentError`, whose
``field`` names the part of the job the coordinator refused).
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any, TypeVar

import grpc

from . import connection
from .convert import submit_request
from .errors import JobFailedError, JobFileError, UnavailableError, from_rpc_error
from .job import JobSpec, load_job
from .models import model_id, resolve_model, resolve_model_argument
from .proto import pb, pb_grpc
from .results import JobResult, Progress, status_name
from .tables import read_all

MODEL_CHUNK_BYTES = 1 << 20
"""Size of the chunks a model is uploaded in (``fmucal_proto::MODEL_CHUNK_BYTES``)."""

PathLike = str | os.PathLike[str]
Job = Mapping[str, Any] | PathLike | JobSpec
"""A job: the path of a TOML job file, a dict with the same structure, or a parsed :class:`JobSpec`."""

T = TypeVar("T")


def build_request(job: Job, base_dir: PathLike | None = None, model: str | None = None) -> pb.SubmitJobRequest:
    """The ``SubmitJobRequest`` the CLI would send for ``job``, without any network.

    ``model`` is the model id to name; by default the SHA-256 of the job's model file (the id
    an upload gives it), or the job's ``[model] id``.

    Raises:
        JobFileError: naming the field of the job or data at fault.
    """
    spec = job if isinstance(job, JobSpec) else load_job(job, base_dir)
    path = resolve_model(spec.model.path) if spec.model.path is not None else None
    tables = read_all(spec)
    return submit_request(spec, tables, model or _model_id(spec, path))


def _model_id(spec: JobSpec, path: Path | None) -> str:
    if path is not None:
        return model_id(path)
    if spec.model.id:
        return spec.model.id
    raise JobFileError("model", "give a path or an id")


class Client:
    """A connection to the coordinator at ``url`` (``http://`` or ``https://``).

    The token is ``token``, else the contents of ``token_file``, else ``FMUCAL_TOKEN``; TLS files
    are the arguments, else ``FMUCAL_TLS_CA``, ``FMUCAL_TLS_CERT`` and ``FMUCAL_TLS_KEY``. The
    constructor waits up to ``connect_timeout`` seconds for the coordinator to accept a
    connection. Use it as a context manager, or call :meth:`close`.

    Raises:
        ConfigurationError: a bad URL, token or TLS file.
        UnavailableError: nothing answers at ``url`` in time.
    """

    def __init__(
        self,
        url: str,
        token: str | None = None,
        token_file: PathLike | None = None,
        tls_ca: PathLike | None = None,
        tls_cert: PathLike | None = None,
        tls_key: PathLike | None = None,
        *,
        connect_timeout: float = 5.0,
    ) -> None:
        self.url = url
        self._metadata: tuple[tuple[str, str], ...] = ()
        token = connection.load_token(token, token_file)
        if token is not None:
            self._metadata = (("authorization", f"Bearer {token}"),)
        self._channel = connection.open_channel(url, connection.credentials(url, tls_ca, tls_cert, tls_key))
        try:
            grpc.channel_ready_future(self._channel).result(timeout=connect_timeout)
        except grpc.FutureTimeoutError:
            self._channel.close()
            why = " (or the TLS handshake failed)" if connection.target(url)[1] else ""
            raise UnavailableError(
                grpc.StatusCode.UNAVAILABLE, f"cannot reach the coordinator at {url} within {connect_timeout} s{why}"
            ) from None
        self._stub = pb_grpc.CalibrationStub(self._channel)  # type: ignore[no-untyped-call]
        self._uploaded: dict[tuple[Path, int, int], str] = {}

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *_: object) -> None:
        self.close()

    def close(self) -> None:
        """Closes the connection."""
        self._channel.close()

    def _call(self, method: Any, request: Any, **kwargs: Any) -> Any:
        try:
            return method(request, metadata=self._metadata, **kwargs)
        except grpc.RpcError as e:
            raise from_rpc_error(e) from None

    def upload_model(self, path: PathLike) -> str:
        """Uploads an ``.fmu`` (or a built-in example: ``example:NAME`` or a bare name, as the
        CLI's MODEL argument) and returns its model id, the SHA-256 of its bytes. A file this
        client uploaded already is not sent again.

        Raises:
            JobFileError: no such file or example (field ``model.path``).
            InvalidArgumentError: the coordinator refused the archive.
        """
        file = resolve_model_argument(path).resolve()
        stat = file.stat()
        key = (file, stat.st_size, stat.st_mtime_ns)
        if key not in self._uploaded:

            def chunks() -> Iterator[pb.UploadModelRequest]:
                with file.open("rb") as f:
                    for chunk in iter(lambda: f.read(MODEL_CHUNK_BYTES), b""):
                        yield pb.UploadModelRequest(chunk=chunk)

            self._uploaded[key] = self._call(self._stub.UploadModel, chunks()).model_id
        return self._uploaded[key]

    def submit(self, job: Job, base_dir: PathLike | None = None) -> str:
        """Submits a calibration and returns its job id. ``job`` is the path of a TOML job file
        or a dict with its structure (relative paths against ``base_dir``, default the current
        folder). The job's model is uploaded first, unless the job names a ``[model] id``.

        Raises:
            JobFileError: the job or its data cannot be read, naming the field.
            InvalidArgumentError: the coordinator refused the job; ``field`` names where.
        """
        spec = job if isinstance(job, JobSpec) else load_job(job, base_dir)
        path = resolve_model(spec.model.path) if spec.model.path is not None else None
        tables = read_all(spec)
        model = self.upload_model(path) if path is not None else _model_id(spec, None)
        return str(self._call(self._stub.SubmitJob, submit_request(spec, tables, model)).job_id)

    def watch(self, job_id: str) -> Iterator[Progress]:
        """The job's progress events in order: the current state at once, one per completed
        batch, and the final state last; the iterator ends with the job.

        Raises:
            NotFoundError: no such job.
        """
        stream = self._call(self._stub.WatchJob, pb.WatchJobRequest(job_id=job_id))
        try:
            for message in stream:
                event = Progress.from_message(message)
                yield event
                if event.ended:
                    return
        except grpc.RpcError as e:
            raise from_rpc_error(e) from None
        finally:
            stream.cancel()

    def status(self, job_id: str) -> str:
        """The job's status now: ``running``, ``succeeded``, ``failed`` or ``cancelled``."""
        return status_name(self._call(self._stub.GetJob, pb.GetJobRequest(job_id=job_id)).status)

    def result(self, job_id: str) -> JobResult:
        """Waits for the job to end and returns its result (a cancelled job's is its best point
        so far).

        Raises:
            JobFailedError: the job failed (its ``result`` holds the best point so far).
            NotFoundError: no such job.
        """
        while True:
            for _ in self.watch(job_id):
                pass
            state = self._call(self._stub.GetJob, pb.GetJobRequest(job_id=job_id))
            result = JobResult.from_message(state)
            if result.status == "failed":
                raise JobFailedError(job_id, state.error, result)
            if result.status in ("succeeded", "cancelled"):
                return result

    def calibrate(self, job: Job, base_dir: PathLike | None = None) -> JobResult:
        """:meth:`submit`, then :meth:`result`."""
        return self.result(self.submit(job, base_dir))

    def cancel(self, job_id: str) -> str:
        """Stops a running job (its best point so far becomes its result) and returns its status
        after the request; a job that has ended keeps its status.

        Raises:
            NotFoundError: no such job.
        """
        return status_name(self._call(self._stub.CancelJob, pb.CancelJobRequest(job_id=job_id)).status)


__all__ = ["Client", "build_request"]
