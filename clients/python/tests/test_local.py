"""Local runs: :func:`fmucal_client.calibrate`, :func:`~fmucal_client.diagnose` and
:func:`~fmucal_client.simulate` run the fmucal binary (``FMUCAL_BIN`` here, the one the
package installed otherwise) with no coordinator. A calibration gives the CLI's result to the
last bit, whatever form the job takes; its result carries the standard errors, correlations,
RMS errors, fit table and warnings; errors name the field; progress arrives in order."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import fmucal_client as fmucal
from conftest import REPO
from fmucal_client import CommandError, JobFileError, Progress, load_job
from fmucal_client import _toml, binary
from fmucal_client.job import job_table

FURUTA = REPO / "examples" / "furuta" / "job.toml"


def test_a_local_calibration_gives_the_cli_result_bit_for_bit(
    cli_furuta: tuple[dict[str, Any], Path], fmucal_bin: Path
) -> None:
    expected, _ = cli_furuta
    result = fmucal.calibrate(FURUTA, progress=False)
    # Python floats parsed from the CLI's JSON are the exact doubles it wrote (shortest form).
    assert result.x_opt == expected["x_opt"]
    assert [v.hex() for v in result.x_opt.values()] == [float(v).hex() for v in expected["x_opt"].values()]
    assert result.f_opt == expected["f_opt"]
    assert (result.evaluations, result.iterations, result.rounds, result.termination) == (
        expected["evaluations"], expected["iterations"], expected["rounds"], expected["termination"])
    assert abs(result.x_opt["armFriction"] - 0.010) < 2e-4


def test_a_local_result_holds_the_analysis_after_the_fit(
    cli_furuta: tuple[dict[str, Any], Path], fmucal_bin: Path
) -> None:
    expected, out = cli_furuta
    result = fmucal.calibrate(FURUTA, progress=False)
    ident = expected["identifiability"]
    assert result.parameter_names == ident["names"] == ["armFriction", "pendulumFriction"]
    assert result.standard_errors == dict(zip(ident["names"], ident["standard_errors"], strict=True))
    assert all(0 < se < 1e-3 for se in result.standard_errors.values())
    assert result.correlation is not None and result.correlation.shape == (2, 2)
    assert result.correlation[0, 0] == pytest.approx(1.0)
    assert set(result.correlations()) == {("armFriction", "pendulumFriction")}
    assert [e.name for e in result.estimates] == ["armFriction", "pendulumFriction"]
    assert result.estimates[0].lower == 0.0 and result.estimates[0].upper == 0.022
    # RMS per output in its unit, and fit %.
    assert set(result.rms) == set(result.fit_percent) == {"armJoint.phi", "pendulumJoint.phi"}
    assert all(90 < f <= 100 for f in result.fit_percent.values()), result.fit_percent
    rows = {o["variable"]: o for o in expected["errors"]["outputs"]}
    assert result.rms == {k: o["calibration"]["rms_optimized"] for k, o in rows.items()}
    assert result.errors is not None and 0 < result.errors.calibration.scaled_rms < 1
    # The fit table as numpy arrays, as fit.csv holds it.
    assert result.fit is not None and list(result.fit) == ["armJoint.phi", "pendulumJoint.phi"]
    series = result.fit["armJoint.phi"]
    assert series.measured.shape == series.start.shape == series.optimized.shape == result.fit.time.shape
    assert len(result.fit.time) > 1000 and result.fit.time[0] == 0.0
    header = (out / "fit.csv").read_text().splitlines()[0]
    assert header.startswith("time,armJoint.phi:measured,armJoint.phi:start,armJoint.phi:optimized")
    assert np.nanmax(np.abs(series.optimized - series.measured)) < np.nanmax(np.abs(series.start - series.measured))
    assert result.warnings == expected["warnings"]
    assert len(result.history["evaluations"]) == len(expected["history"])
    assert "armFriction = " in repr(result) and "standard error" in repr(result)
    assert "<table>" in result._repr_html_()
    assert "termination:" in result.summary


def test_pandas_and_matplotlib_views(fmucal_bin: Path) -> None:
    pd = pytest.importorskip("pandas")
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    result = fmucal.calibrate(FURUTA, progress=False)
    frame = result.fit.to_pandas()  # type: ignore[union-attr]
    assert isinstance(frame, pd.DataFrame) and frame.index.name == "time"
    assert list(frame.columns[:3]) == ["armJoint.phi:measured", "armJoint.phi:start", "armJoint.phi:optimized"]
    estimates = result.to_pandas()
    assert list(estimates.index) == ["armFriction", "pendulumFriction"]
    assert estimates.loc["armFriction", "value"] == result.x_opt["armFriction"]
    fig = result.plot()
    assert len(fig.axes) == 2


def test_a_job_as_a_dict_or_a_jobspec_gives_the_same_result(fmucal_bin: Path) -> None:
    by_path = fmucal.calibrate(FURUTA, progress=False)
    table = tomllib.loads(FURUTA.read_text())
    by_dict = fmucal.calibrate(table, base_dir=FURUTA.parent, progress=False)
    by_spec = fmucal.calibrate(load_job(FURUTA), progress=False)
    assert by_path.x_opt == by_dict.x_opt == by_spec.x_opt


def test_progress_arrives_in_order_and_out_keeps_the_folder(tmp_path: Path, fmucal_bin: Path) -> None:
    events: list[Progress] = []
    result = fmucal.calibrate(FURUTA, out=tmp_path / "run", progress=events.append, workers=1)
    assert events, "no progress event"
    assert [e.evaluations for e in events] == sorted(e.evaluations for e in events)
    assert events[-1].evaluations <= result.evaluations
    assert all(e.best_f >= result.f_opt for e in events if math.isfinite(e.best_f))
    assert {"result.json", "fit.csv", "convergence.csv", "fit.png"} <= {p.name for p in (tmp_path / "run").iterdir()}


def test_an_error_is_an_exception_naming_the_field(tmp_path: Path, fmucal_bin: Path) -> None:
    text = FURUTA.read_text().replace('variable = "armJoint.phi"', 'variable = "armJoint.nothing"')
    data = f'path = "{FURUTA.parent}/FurutaData.mat"'
    (tmp_path / "job.toml").write_text(text.replace('path = "FurutaData.mat"', data))
    with pytest.raises(CommandError) as caught:
        fmucal.calibrate(tmp_path / "job.toml", progress=False)
    assert caught.value.field == "outputs[0].variable", caught.value.message
    assert "armJoint.nothing" in caught.value.message and caught.value.exit_code == 1
    # A dict is read in Python first: a bad field is refused before any process starts.
    table = tomllib.loads(FURUTA.read_text())
    table["parameters"][0]["lower"] = "abc"
    with pytest.raises(JobFileError) as refused:
        fmucal.calibrate(table, base_dir=FURUTA.parent, progress=False)
    assert refused.value.field == "parameters[0].lower"
    # A TOML syntax error keeps the parser's lines.
    (tmp_path / "broken.toml").write_text("[model\n")
    with pytest.raises(CommandError) as syntax:
        fmucal.calibrate(tmp_path / "broken.toml", progress=False)
    assert syntax.value.field == "toml" and "\n" in syntax.value.message


def test_simulate_returns_the_recorded_variables(fmucal_bin: Path) -> None:
    sim = fmucal.simulate("example:furuta", stop_time=1.0, output_interval=0.1, set={"armFriction": 0.02},
                          outputs=["armJoint.phi", "pendulumJoint.phi"])
    assert list(sim.values) == ["armJoint.phi", "pendulumJoint.phi"]
    assert sim.time[0] == 0.0 and sim.time[-1] == pytest.approx(1.0) and len(sim.time) == 11
    assert sim["armJoint.phi"].shape == sim.time.shape
    with pytest.raises(CommandError, match="nothing"):
        fmucal.simulate("example:furuta", stop_time=1.0, outputs=["nothing"])


def test_diagnose_names_the_missing_friction(tmp_path: Path, fmucal_bin: Path) -> None:
    job = REPO / "examples" / "diagnose" / "job.toml"
    if not (job.parent / "data.csv").is_file():
        pytest.fail("examples/diagnose/data.csv is missing (bash examples/diagnose/generate.sh writes it)")
    diagnosis = fmucal.diagnose(job, top=2, progress=False, out=tmp_path / "d")
    assert diagnosis.named, repr(diagnosis)
    assert "pendulumJoint" in " ".join(diagnosis.named)
    assert diagnosis.fitted and diagnosis.report["conclusion"]
    assert "[[effects]]" in diagnosis.job_toml
    assert (tmp_path / "d" / "report.json").is_file()


def test_without_a_binary_the_error_says_where_it_looked(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("FMUCAL_BIN", "")
    monkeypatch.setenv("PATH", str(tmp_path))
    monkeypatch.setattr(binary, "_candidates", lambda: [tmp_path / "bin" / "fmucal"])
    with pytest.raises(fmucal.ConfigurationError, match="FMUCAL_BIN.*pip install ./clients/python"):
        fmucal.calibrate(FURUTA, progress=False)


# The jobs with `set_from` need an earlier stage's result; what it gives is merged into `set`,
# which the others cover.
ROUND_TRIP = sorted(p for p in (REPO / "examples").rglob("*.toml") if "set_from" not in p.read_text())


@pytest.mark.parametrize("job", ROUND_TRIP, ids=lambda p: str(p.relative_to(REPO)))
def test_a_jobspec_written_as_toml_reads_back_the_same(job: Path) -> None:
    spec = load_job(job)
    assert load_job(tomllib.loads(_toml.dumps(job_table(spec))), job.parent) == spec


def test_toml_values_keep_every_bit_and_character() -> None:
    table = {"a": {"x": 0.1, "y": 1e-300, "z": -0.0, "big": 1e21, "i": 3, "inf": math.inf, "ninf": -math.inf,
                   "t": True, "s": 'q"\\\n\t\x01\x7fé😀', "weird key": [1.5, "two"], "inline": {"k": 2.0}},
             "list": [{"name": "p", "v": 5e-324}, {"name": "q", "v": 2.5}]}
    back = tomllib.loads(_toml.dumps(table))
    assert back == table
    assert math.copysign(1.0, back["a"]["z"]) == -1.0
    assert math.isnan(tomllib.loads(_toml.dumps({"a": {"n": math.nan}}))["a"]["n"])


def test_the_progress_setting_of_the_binary_is_checked(fmucal_bin: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FMUCAL_PROGRESS", "xml")  # the package sets json for its own runs
    from fmucal_client import _process

    with pytest.raises(CommandError) as caught:
        _process.run(str(fmucal_bin), ["calibrate", str(FURUTA), "--out", "/nonexistent/never"])
    assert caught.value.field == "FMUCAL_PROGRESS" and '"xml"' in caught.value.message
