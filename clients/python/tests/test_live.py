"""The client against a real coordinator and workers (started by ``tests/python_client.rs``): a
job submitted from Python gives the CLI's result bit for bit, progress arrives in order, errors
come back as exceptions naming the field, and cancelling stops a job."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import time
import tomllib
from pathlib import Path
from typing import Any

import pytest

from conftest import REPO
from fmucal_client import (
    AuthenticationError,
    Client,
    InvalidArgumentError,
    JobFileError,
    NotFoundError,
    Progress,
)
from fmucal_client.models import example_path

FURUTA = REPO / "examples" / "furuta" / "job.toml"


def furuta_dict() -> dict[str, Any]:
    """The Furuta job as a dict (its paths are relative to examples/furuta)."""
    return tomllib.loads(FURUTA.read_text())


@pytest.mark.parametrize("job", ["examples/furuta/job.toml", "examples/furuta_experiments/job.toml"])
def test_python_gives_the_cli_result_bit_for_bit(
    job: str, client: Client, coordinator_url: str, token: str, fmucal_bin: Path, tmp_path: Path
) -> None:
    # The CLI's tolerance guard may refit at a tighter tolerance (it simulates locally; a job
    # from Python runs at the job's tolerance): compare the runs without it, on a copy of the
    # example's folder.
    copy = tmp_path / "job"
    shutil.copytree((REPO / job).parent, copy)
    unguarded = copy / Path(job).name
    text = unguarded.read_text()
    if "[simulation]" in text:
        text = text.replace("[simulation]", "[simulation]\ntolerance_guard = false", 1)
    else:
        text += "\n[simulation]\ntolerance_guard = false\n"
    unguarded.write_text(text)
    out = tmp_path / "out"
    cli = subprocess.run(
        [str(fmucal_bin), "calibrate", str(unguarded), "--coordinator", coordinator_url, "--out", str(out)],
        env={**os.environ, "FMUCAL_TOKEN": token},
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert cli.returncode == 0, cli.stderr
    expected = json.loads((out / "result.json").read_text())

    result = client.calibrate(REPO / job)
    assert result.status == "succeeded"
    assert result.termination == expected["termination"]
    # Python floats parsed from the CLI's JSON are the exact doubles it wrote (shortest form).
    assert result.x_opt == expected["x_opt"]
    assert result.f_opt == expected["f_opt"]
    assert (result.evaluations, result.iterations, result.rounds) == (
        expected["evaluations"],
        expected["iterations"],
        expected["rounds"],
    )
    assert {"armFriction", "pendulumFriction"} <= set(result.x_opt)
    assert abs(result.x_opt["armFriction"] - 0.010) < 2e-4
    # The warnings the result alone allows come back too, as the CLI wrote them.
    assert all(w in expected["warnings"] for w in result.warnings)


def test_a_result_at_a_bound_comes_back_with_its_warning(client: Client) -> None:
    job = furuta_dict()
    # The truth (0.010) lies above this upper bound.
    job["parameters"][0]["upper"] = 0.008
    job["parameters"][0]["start"] = 0.005
    result = client.calibrate(job, base_dir=FURUTA.parent)
    assert result.status == "succeeded"
    assert any("armFriction" in w and "upper bound" in w for w in result.warnings), result.warnings


def test_progress_events_arrive_in_order_and_end_with_the_final_state(client: Client) -> None:
    # Tight tolerances: about 80 batches over a second, so watching starts well before the end.
    job = furuta_dict()
    job["optimizer"].update(x_tol=1e-9, f_tol=0.0, max_iters=300)
    job_id = client.submit(job, base_dir=FURUTA.parent)
    events = list(client.watch(job_id))
    result = client.result(job_id)

    first, last = events[0], events[-1]
    assert last.status == "succeeded" and last.ended
    assert all(e.status == "running" and not e.ended for e in events[:-1])
    # Every batch after the first event is reported once, in order.
    batches = [e.rounds for e in events if e.batch_wall_s > 0]
    assert batches == list(range(first.rounds + 1, last.rounds + 1))
    assert len(batches) >= 10
    assert [e.rounds for e in events] == sorted(e.rounds for e in events)
    assert [e.evaluations for e in events] == sorted(e.evaluations for e in events)
    finite = [e.best_f for e in events if e.evaluations > 0]
    assert finite == sorted(finite, reverse=True)
    # The final event is the result.
    assert (last.rounds, last.evaluations, last.best_f) == (result.rounds, result.evaluations, result.f_opt)
    assert last.best_x == (result.x_opt["armFriction"], result.x_opt["pendulumFriction"])
    # Watching a finished job gives its final state alone.
    assert list(client.watch(job_id)) == [last]


def mutated(edit: str) -> dict[str, Any]:
    """The Furuta job with one mistake."""
    job = furuta_dict()
    if edit == "bad bound":
        job["parameters"][0]["lower"] = 0.5
    elif edit == "misspelled parameter":
        job["parameters"][1]["name"] = "pendulumFricton"
    elif edit == "unknown output":
        job["outputs"][1]["variable"] = "pendulumJoint.ph"
    elif edit == "unknown column":
        job["outputs"][0]["column"] = "psi"
    elif edit == "bad tolerance":
        job["simulation"]["tolerance"] = 1e-300
    return job


@pytest.mark.parametrize(
    ("edit", "field", "says"),
    [
        ("bad bound", "parameters[0].lower", '"armFriction": lower 0.5 is above upper 0.022'),
        ("misspelled parameter", "parameters[1].name", 'unknown variable "pendulumFricton"'),
        ("unknown output", "outputs[1].variable", 'unknown variable "pendulumJoint.ph"'),
        ("unknown column", "outputs[0].column", 'no column "psi" in the data; the closest: "phi"'),
        ("bad tolerance", "simulation.tolerance", "is not in [1e-14, 1)"),
    ],
)
def test_a_refused_job_is_an_exception_naming_the_field(client: Client, edit: str, field: str, says: str) -> None:
    with pytest.raises(InvalidArgumentError) as caught:
        client.submit(mutated(edit), base_dir=FURUTA.parent)
    e = caught.value
    assert e.field == field, e.details
    assert e.details.startswith(f"{field}: ") and says in e.details, e.details


def test_a_client_side_mistake_names_the_field_before_anything_is_sent(client: Client) -> None:
    job = furuta_dict()
    job["parameters"][1]["lower"] = "zero"
    with pytest.raises(JobFileError) as caught:
        client.submit(job, base_dir=FURUTA.parent)
    assert caught.value.field == "parameters[1].lower"
    assert str(caught.value) == "parameters[1].lower: expected a number, got 'zero' (a string)"


def test_tokens_come_from_the_argument_a_file_or_the_environment(
    coordinator_url: str, token: str, fmucal_bin: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("FMUCAL_TOKEN", raising=False)
    for bad in (Client(coordinator_url, token="not-the-token"), Client(coordinator_url)):
        with bad, pytest.raises(AuthenticationError) as caught:
            bad.submit(FURUTA)
        assert caught.value.details == "missing or wrong bearer token"
    file = tmp_path / "token"
    file.write_text(f"  {token}\n")
    with Client(coordinator_url, token_file=file) as c:
        assert len(c.upload_model("example:furuta")) == 64
    monkeypatch.setenv("FMUCAL_TOKEN", token)
    with Client(coordinator_url) as c:
        assert c.status(c.submit(FURUTA)) in ("running", "succeeded")


def test_an_unknown_job_is_not_found(client: Client) -> None:
    unknown = 'job "no-such-job" not found'
    with pytest.raises(NotFoundError, match=unknown):
        next(client.watch("no-such-job"))
    for call in (client.result, client.cancel, client.status):
        with pytest.raises(NotFoundError, match=unknown):
            call("no-such-job")


def test_upload_gives_the_sha256_and_refuses_what_is_not_an_fmu(client: Client, tmp_path: Path) -> None:
    furuta = example_path("furuta")
    expected = hashlib.sha256(furuta.read_bytes()).hexdigest()
    assert client.upload_model("example:furuta") == expected
    assert client.upload_model("furuta") == expected
    assert client.upload_model(furuta) == expected
    junk = tmp_path / "junk.fmu"
    junk.write_bytes(b"PK\x03\x04 this is no zip archive")
    with pytest.raises(InvalidArgumentError):
        client.upload_model(junk)


def test_a_job_naming_an_uploaded_model_id_runs_without_uploading(client: Client) -> None:
    job = furuta_dict()
    job["model"] = {"id": client.upload_model("example:furuta")}
    by_id = client.calibrate(job, base_dir=FURUTA.parent)
    by_path = client.calibrate(FURUTA)
    assert by_id.status == "succeeded"
    assert (by_id.x_opt, by_id.f_opt) == (by_path.x_opt, by_path.f_opt)


def test_cancel_stops_a_running_job_and_keeps_its_best_point(client: Client) -> None:
    job = furuta_dict()
    # Differential evolution with its stopping rules off runs until it is stopped.
    job["optimizer"] = {"algorithm": "differential-evolution", "population": 12, "x_tol": 0.0, "f_tol": 0.0,
                        "max_iters": 1_000_000}
    job_id = client.submit(job, base_dir=FURUTA.parent)
    for event in client.watch(job_id):
        if event.rounds >= 2:
            break
    assert event.status == "running"
    assert client.cancel(job_id) == "cancelled"

    after = list(client.watch(job_id))
    assert [e.status for e in after] == ["cancelled"]
    result = client.result(job_id)
    assert result.status == "cancelled"
    assert result.evaluations >= 2 * 12
    assert set(result.x_opt) == {"armFriction", "pendulumFriction"}
    assert 0.0 <= result.x_opt["armFriction"] <= 0.022 and 0.0 <= result.x_opt["pendulumFriction"] <= 0.012
    assert result.f_opt == after[0].best_f
    # It stays stopped: no more evaluations, and cancelling again changes nothing.
    time.sleep(1.0)
    assert client.result(job_id).evaluations == result.evaluations
    assert client.cancel(job_id) == "cancelled"
    assert client.status(job_id) == "cancelled"



def test_calibrate_on_a_coordinator_gives_the_local_cli_optimum_bit_for_bit(
    coordinator_url: str, token: str, cli_furuta: tuple[dict[str, Any], Path]
) -> None:
    import fmucal_client as fmucal

    expected, _ = cli_furuta
    events: list[Progress] = []
    result = fmucal.calibrate(FURUTA, coordinator=coordinator_url, token=token, progress=events.append)
    assert result.x_opt == expected["x_opt"]
    assert result.termination == expected["termination"]
    # The CLI's tolerance guard then finds that a tighter tolerance moves that optimum by less
    # than the job's x_tol, so it keeps it without a refit (a job on a pool runs at the job's
    # own tolerance).
    guard = expected["tolerance_guard"]
    assert "refit" not in guard and guard["linearised_move"]["refit_needed"] is False
    assert result.evaluations == expected["evaluations"]
    assert events and events[-1].evaluations == result.evaluations
    # What the coordinator does not compute stays empty rather than made up.
    assert result.standard_errors == {} and result.fit is None and result.rms == {}
    with pytest.raises(ValueError, match="no fit table"):
        result.plot()
    with pytest.raises(TypeError, match="no workers or out"):
        fmucal.calibrate(FURUTA, coordinator=coordinator_url, token=token, workers=2)


def test_diagnose_on_a_coordinator_names_what_a_local_diagnosis_names(
    coordinator_url: str, token: str, tmp_path: Path
) -> None:
    import fmucal_client as fmucal

    job = REPO / "examples" / "diagnose" / "job.toml"
    remote = fmucal.diagnose(job, coordinator=coordinator_url, token=token, top=2, progress=False)
    local = fmucal.diagnose(job, top=2, progress=False)
    assert remote.named and remote.named == local.named
    assert remote.fitted == local.fitted
