"""What the coordinator reports about a job, as plain Python values: progress events
(:class:`Progress`) and the final result (:class:`JobResult`)."""

from __future__ import annotations

from dataclasses import dataclass, field

from .proto import pb

ENDED = ("succeeded", "failed", "cancelled")
"""The statuses of a job that has ended."""


def status_name(status: int) -> str:
    """``"running"`` for ``JOB_STATUS_RUNNING``, and so on."""
    try:
        return pb.JobStatus.Name(status).removeprefix("JOB_STATUS_").lower()
    except ValueError:
        return f"unknown({status})"


@dataclass(frozen=True)
class Progress:
    """One ``WatchJob`` event: sent when watching starts, after each completed batch
    (``batch_wall_s > 0``) and when the job ends (``status`` then is one of :data:`ENDED`)."""

    iteration: int
    evaluations: int
    best_f: float
    best_x: tuple[float, ...]
    """The best point's values, in the job's calibrated order (parameters, per-experiment ones
    expanded as NAME@EXPERIMENT, then effects)."""
    batch_wall_s: float
    status: str
    rounds: int

    @property
    def ended(self) -> bool:
        """Whether this is the job's last event."""
        return self.status in ENDED

    @classmethod
    def from_message(cls, m: pb.WatchJobResponse) -> Progress:
        """The event of a ``WatchJobResponse``."""
        return cls(m.iteration, m.evaluations, m.best_f, tuple(m.best_x), m.batch_wall_s, status_name(m.status),
                   m.rounds)


@dataclass(frozen=True)
class EvaluatedPoint:
    """A point of an evaluate-points job: its values, objective value or failure, residuals."""

    x: tuple[float, ...]
    ok: bool
    value: float
    residuals: tuple[float, ...]
    message: str


@dataclass(frozen=True)
class JobResult:
    """A finished job: its status and result (``x_opt`` by calibrated name)."""

    job_id: str
    status: str
    x_opt: dict[str, float]
    f_opt: float
    iterations: int
    evaluations: int
    rounds: int
    failed_evaluations: int
    termination: str
    elapsed_s: float
    error: str = ""
    evaluated: list[EvaluatedPoint] = field(default_factory=list)
    #: The checks the result alone allows, one sentence each: a parameter at a bound, a run
    #: ended by its budget rather than a tolerance (``fmucal calibrate`` adds more).
    warnings: list[str] = field(default_factory=list)

    @classmethod
    def from_message(cls, m: pb.GetJobResponse) -> JobResult:
        """The result of a ``GetJobResponse`` (zeros and an empty ``x_opt`` without a result)."""
        r = m.result
        return cls(
            job_id=m.job_id,
            status=status_name(m.status),
            x_opt=dict(zip(r.names, r.x_opt)),
            f_opt=r.f_opt,
            iterations=r.iterations,
            evaluations=r.evaluations,
            rounds=r.rounds,
            failed_evaluations=r.failed_evaluations,
            termination=r.termination,
            elapsed_s=r.elapsed_s,
            error=m.error,
            evaluated=[EvaluatedPoint(tuple(p.x), p.ok, p.value, tuple(p.residuals), p.message) for p in r.evaluated],
            warnings=list(r.warnings),
        )
