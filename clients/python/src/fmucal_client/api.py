"""One call per task: :func:`calibrate`, :func:`diagnose` and :func:`simulate`.

With no ``coordinator``, each runs the ``fmucal`` binary the package installed
(:mod:`fmucal_client.binary`) as a child process, exactly as the command line would:
``fmucal calibrate JOB --out DIR`` starts an in-process coordinator and worker processes
(``workers``, default the job's ``[workers] count``, else one per core), and the result is read
from ``DIR``. The result therefore is the CLI's, to the last bit. With ``coordinator=URL``,
:func:`calibrate` submits the job over gRPC (:class:`~fmucal_client.Client`) to a coordinator
and its pool of workers, and :func:`diagnose` runs ``fmucal diagnose --coordinator URL``.

A job is the path of a TOML job file, a dict with its structure (relative paths against
``base_dir``, default the current folder), or a :class:`~fmucal_client.JobSpec`. Progress
shows as a tqdm bar (``tqdm.auto``, so a widget in a notebook) when tqdm is installed; pass
``progress=False`` to turn it off, or a callable to receive each :class:`Progress` yourself.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from . import _process, _toml, binary
from .calibration import CalibrationResult, Diagnosis, SimulationResult
from .errors import JobFileError
from .job import JobSpec, job_table, load_job
from .results import Progress

PathLike = str | os.PathLike[str]
Job = PathLike | Mapping[str, Any] | JobSpec
"""A job: a TOML job file's path, a dict of the same structure, or a :class:`JobSpec`."""
ProgressOption = bool | Callable[[Progress], None] | None


def calibrate(
    job: Job,
    *,
    coordinator: str | None = None,
    workers: int | None = None,
    out: PathLike | None = None,
    base_dir: PathLike | None = None,
    progress: ProgressOption = None,
    token: str | None = None,
    token_file: PathLike | None = None,
    tls_ca: PathLike | None = None,
    tls_cert: PathLike | None = None,
    tls_key: PathLike | None = None,
) -> CalibrationResult:
    """Calibrates ``job`` and returns its :class:`CalibrationResult`.

    Locally (no ``coordinator``): runs ``fmucal calibrate`` with ``workers`` worker processes
    and writes its folder (``result.json``, ``fit.csv``, ``convergence.csv`` and the plots) to
    ``out``, or to a temporary folder removed after reading. On a coordinator: submits the job
    (token from ``token``, ``token_file`` or ``FMUCAL_TOKEN``; TLS files as for
    :class:`~fmucal_client.Client`) and waits for its result; ``workers`` and ``out`` do not
    apply there.

    Raises:
        CommandError: the local run failed; ``field`` names the job's field at fault.
        JobFileError: the job cannot be read (dict or coordinator runs check it in Python).
        ServerError: the coordinator refused the job (``InvalidArgumentError.field``).
        JobFailedError: the job failed on the coordinator.
    """
    if coordinator is not None:
        if workers is not None or out is not None:
            raise TypeError("calibrate(coordinator=...) takes no workers or out: the pool and the client decide")
        return _calibrate_remote(job, coordinator, base_dir, progress, token, token_file, tls_ca, tls_cert, tls_key)
    with _JobFile(job, base_dir) as job_file, _OutDir(out) as folder:
        args: list[PathLike] = ["calibrate", job_file.path, "--out", folder]
        if workers is not None:
            args += ["--workers", str(workers)]
        with _Bar(progress, "calibrating", job_file.max_fevals) as bar:
            done = _process.run(binary.require(), args, on_progress=bar.update, env={"FMUCAL_PROGRESS": "json"})
        return CalibrationResult.read(Path(folder), summary=done.stdout)


def diagnose(
    job: Job,
    *,
    coordinator: str | None = None,
    workers: int | None = None,
    out: PathLike | None = None,
    top: int | None = None,
    base_dir: PathLike | None = None,
    progress: ProgressOption = None,
    token: str | None = None,
    token_file: PathLike | None = None,
    tls_ca: PathLike | None = None,
) -> Diagnosis:
    """Looks for what the model of ``job`` lacks (``fmucal diagnose``) and returns the
    :class:`Diagnosis`: ``report.json``, the job with the named effects added, the summary.
    ``out`` keeps the folder (with the residual plots); ``top`` overrides ``[diagnose] top``.
    With ``coordinator=URL`` the fits run on that coordinator's workers. Its progress is its
    rounds: a tqdm bar shows each ``round N: ...`` line, and a callable ``progress`` receives
    them as text.

    Raises:
        CommandError: the run failed; ``field`` names the job's field at fault.
    """
    with _JobFile(job, base_dir) as job_file, _OutDir(out) as folder:
        args: list[PathLike] = ["diagnose", job_file.path, "--out", folder]
        if workers is not None:
            args += ["--workers", str(workers)]
        if top is not None:
            args += ["--top", str(top)]
        env = {}
        if coordinator is not None:
            args += ["--coordinator", coordinator]
            if token_file is not None:
                args += ["--token-file", _process.absolute(token_file)]
            if tls_ca is not None:
                args += ["--tls-ca", _process.absolute(tls_ca)]
            if token is not None:
                env["FMUCAL_TOKEN"] = token
        with _Bar(progress, "diagnosing", None, counts=False) as bar:
            done = _process.run(binary.require(), args, on_status=bar.status, env=env)
        report = json.loads((Path(folder) / "report.json").read_text(encoding="utf-8"))
        return Diagnosis(report, (Path(folder) / "job.toml").read_text(encoding="utf-8"), done.stdout)


def simulate(
    model: PathLike,
    *,
    start_time: float | None = None,
    stop_time: float | None = None,
    output_interval: float | None = None,
    set: Mapping[str, float | bool | str] | None = None,  # noqa: A002 (the CLI's --set)
    input: PathLike | None = None,  # noqa: A002 (the CLI's --input)
    outputs: Sequence[str] = (),
    interface: str | None = None,
    tolerance: float | None = None,
    solver: str | None = None,
    max_step: float | None = None,
    timeout: float | None = None,
) -> SimulationResult:
    """Simulates ``model`` (an ``.fmu`` path or a built-in example's name) once with
    ``fmucal simulate`` and returns the recorded variables (default: the outputs, else the
    states). ``set`` fixes parameters or start values; ``input`` is a CSV of input signals
    (a ``time`` column, then one column per input).

    Raises:
        CommandError: naming the option or variable at fault.
    """
    with tempfile.TemporaryDirectory(prefix="fmucal-simulate-") as tmp:
        csv_path = Path(tmp) / "result.csv"
        args: list[PathLike] = ["simulate", _model_argument(model), "--out", csv_path]
        options = {"--start-time": start_time, "--stop-time": stop_time, "--output-interval": output_interval,
                   "--interface": interface, "--tolerance": tolerance, "--solver": solver, "--max-step": max_step,
                   "--timeout": timeout}
        for flag, v in options.items():
            if v is not None:
                args += [flag, repr(v) if isinstance(v, float) else str(v)]
        for name, v in (set or {}).items():
            text = ("true" if v else "false") if isinstance(v, bool) else repr(v) if isinstance(v, float) else str(v)
            args += ["--set", f"{name}={text}"]
        if input is not None:
            args += ["--input", _process.absolute(input)]
        for name in outputs:
            args += ["--output", name]
        _process.run(binary.require(), args)
        return SimulationResult.read(csv_path)


def _model_argument(model: PathLike) -> str:
    text = os.fspath(model)
    return str(_process.absolute(text)) if not text.startswith("example:") and Path(text).exists() else text


def _calibrate_remote(job: Job, url: str, base_dir: PathLike | None, progress: ProgressOption, token: str | None,
                      token_file: PathLike | None, tls_ca: PathLike | None, tls_cert: PathLike | None,
                      tls_key: PathLike | None) -> CalibrationResult:
    from .client import Client

    spec = job if isinstance(job, JobSpec) else load_job(job, base_dir)
    with Client(url, token=token, token_file=token_file, tls_ca=tls_ca, tls_cert=tls_cert, tls_key=tls_key) as c:
        job_id = c.submit(spec)
        with _Bar(progress, "calibrating", spec.optimizer.max_fevals) as bar:
            for event in c.watch(job_id):
                bar.update({"round": event.rounds, "iteration": event.iteration, "evaluations": event.evaluations,
                            "best_f": event.best_f})
        return CalibrationResult.from_job_result(c.result(job_id))


class _JobFile:
    """The job as a file the binary can read: a path as given, else a temporary TOML file whose
    paths are absolute (so that it reads the same data from the temporary folder)."""

    def __init__(self, job: Job, base_dir: PathLike | None) -> None:
        self._tmp: tempfile.TemporaryDirectory[str] | None = None
        self.max_fevals: int | None = None
        if isinstance(job, (str, os.PathLike)):
            self.path = _process.absolute(job)
            try:
                self.max_fevals = load_job(self.path).optimizer.max_fevals
            except (JobFileError, OSError):
                pass  # the binary says what is wrong, naming the field
            return
        if isinstance(job, JobSpec):
            table = job_table(job)
        elif isinstance(job, Mapping):
            spec = load_job(job, base_dir)  # refuses a bad job naming the field, before any process
            table = _absolute_paths(job, Path(base_dir) if base_dir is not None else Path.cwd())
            job = spec
        else:
            raise TypeError(f"a job is a path, a dict or a JobSpec, not {type(job).__name__}")
        self.max_fevals = job.optimizer.max_fevals
        self._tmp = tempfile.TemporaryDirectory(prefix="fmucal-job-")
        self.path = Path(self._tmp.name) / "job.toml"
        self.path.write_text(_toml.dumps(table), encoding="utf-8")

    def __enter__(self) -> _JobFile:
        return self

    def __exit__(self, *_: object) -> None:
        if self._tmp is not None:
            self._tmp.cleanup()


def _absolute_paths(table: Mapping[str, Any], base: Path) -> dict[str, Any]:
    """A copy of a job table with its file paths (model, data, set_from, experiments' data)
    made absolute against ``base``."""

    def fix(t: Any, key: str) -> Any:
        if not isinstance(t, Mapping) or not isinstance(t.get(key), str) or t[key].startswith("example:"):
            return t
        return {**t, key: str((base / t[key]).absolute())}

    out = dict(table)
    for name in ("model", "data"):
        out[name] = fix(out.get(name), "path") if name in out else None
    if isinstance(out.get("simulation"), Mapping):
        out["simulation"] = fix(out["simulation"], "set_from")
    if isinstance(out.get("experiments"), Sequence):
        out["experiments"] = [
            {**x, "data": fix(x["data"], "path")} if isinstance(x, Mapping) and "data" in x else x
            for x in out["experiments"]
        ]
    return {k: v for k, v in out.items() if v is not None}


class _OutDir:
    """``out`` (made if missing), else a temporary folder removed on exit."""

    def __init__(self, out: PathLike | None) -> None:
        self._tmp = None if out is not None else tempfile.mkdtemp(prefix="fmucal-out-")
        self.path = _process.absolute(out) if out is not None else Path(self._tmp or "")

    def __enter__(self) -> Path:
        return self.path

    def __exit__(self, *_: object) -> None:
        if self._tmp is not None:
            shutil.rmtree(self._tmp, ignore_errors=True)


class _Bar:
    """The progress display: a tqdm bar of evaluations (when tqdm is installed and progress is
    not False), or the caller's callable."""

    def __init__(self, progress: ProgressOption, what: str, total: int | None, *, counts: bool = True) -> None:
        self._callback = progress if callable(progress) else None
        self._bar: Any = None
        self._last = (0, 0)
        self._offset = (0, 0)
        self._what = what
        if progress is None or progress is True:
            try:
                from tqdm.auto import tqdm
            except ImportError:
                if progress is True:
                    raise ImportError("progress=True needs tqdm: pip install tqdm") from None
            else:
                shape = {"unit": "eval"} if counts else {"bar_format": "{desc} [{elapsed}]"}
                self._bar = tqdm(total=total, desc=what, dynamic_ncols=True, leave=True, **shape)

    def update(self, event: Mapping[str, Any]) -> None:
        """One progress event of the binary. A refit at a tighter tolerance (the tolerance
        guard's) is a second calibration whose counts start again from 0: its events continue
        the first one's counts, as the result's do."""
        best_f = event.get("best_f")
        best_f = float("inf") if best_f is None else float(best_f)
        evaluations, rounds = int(event.get("evaluations", 0)), int(event.get("round", 0))
        if evaluations < self._last[0]:
            self._offset = (self._offset[0] + self._last[0], self._offset[1] + self._last[1])
        self._last = (evaluations, rounds)
        p = Progress(iteration=int(event.get("iteration", 0)), evaluations=self._offset[0] + evaluations,
                     best_f=best_f, best_x=(), batch_wall_s=0.0, status="running", rounds=self._offset[1] + rounds)
        if self._callback is not None:
            self._callback(p)
        if self._bar is not None:
            self._bar.update(max(0, p.evaluations - self._bar.n))
            self._bar.set_postfix(round=p.rounds, best_f=f"{p.best_f:.6e}", refresh=False)

    def status(self, line: str) -> None:
        """A status line of the binary: a diagnosis's ``round N: ...`` lines are its progress."""
        if not line.startswith("round "):
            return
        if self._callback is not None:
            self._callback(line)  # type: ignore[arg-type]
        elif self._bar is not None:
            self._bar.set_description(f"{self._what}: {line}")

    def __enter__(self) -> _Bar:
        return self

    def __exit__(self, *_: object) -> None:
        if self._bar is not None:
            self._bar.close()
