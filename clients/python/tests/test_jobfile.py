"""Reading job files and data without a coordinator: every mistake is a JobFileError naming
its field, paths are resolved against the job file's folder, and the data reaches the request
as the file holds it."""

from __future__ import annotations

import hashlib
import math
import sys
from pathlib import Path

import pytest

from conftest import REPO
from fmucal_client import JobFileError, build_request, load_job
from fmucal_client import binary
from fmucal_client.tables import read_table

JOB = (REPO / "shared" / "tests" / "data" / "minimal_job.toml").read_text() + """[[parameters]]
name = "c"
start = 1
lower = 0
upper = 3
"""
"""The Rust tests' minimal job (one output `y`, parameter `k`) with a second parameter `c`
written with integers."""


def write_job(folder: Path, text: str = JOB, data: str = "time,y\n0,1\n1,2\n") -> Path:
    """A job file with a model file and a data file beside it."""
    (folder / "m.fmu").write_bytes(b"not really an fmu")
    (folder / "d.csv").write_text(data)
    job = folder / "job.toml"
    job.write_text(text)
    return job


def table_added(table: str) -> tuple[str, str]:
    """The edit of JOB that adds ``table`` (before its ``[data]`` table)."""
    return "[data]", f"{table}\n[data]"


def error_of(folder: Path, text: str, data: str = "time,y\n0,1\n1,2\n") -> JobFileError:
    with pytest.raises(JobFileError) as caught:
        build_request(write_job(folder, text, data))
    return caught.value


@pytest.mark.parametrize(
    ("edit", "field", "says"),
    [
        (("upper = 3", 'upper = "abc"'), "parameters[1].upper", "expected a number, got 'abc' (a string)"),
        (("upper = 3\n", ""), "parameters[1].upper", "missing"),
        (("[data]", "[data]\nbogus = 1"), "data.bogus", "unknown field"),
        (table_added("[optimizer]\nalgorithm = \"simplex\""), "optimizer.algorithm",
         '"simplex" is not nelder-mead, differential-evolution, genetic, cma-es or least-squares'),
        (table_added("[optimizer]\nmax_iters = -5"), "optimizer.max_iters", "-5 is not a non-negative"),
        (table_added("[optimizer]\nseed = 1.5"), "optimizer.seed", "expected a non-negative integer"),
        (table_added("[optimizer]\nmutation_rate = 0.02"), "optimizer.mutation_rate",
         "applies to genetic, not nelder-mead (the default algorithm)"),
        (table_added("[optimizer]\nalgorithm = \"least-squares\"\npopulation = 4"), "optimizer.population",
         "applies to differential-evolution, genetic or cma-es, not least-squares"),
        (table_added("[optimizer]\nalgorithm = \"genetic\"\nparallel = false"), "optimizer.parallel",
         "applies to nelder-mead, not genetic"),
        (table_added("[simulation]\nsolver = \"rk4\""), "simulation.solver", 'unknown solver "rk4"'),
        (table_added("[simulation]\nset = { g = [1, 2] }"), "simulation.set.g",
         "expected a number, true/false or a string"),
        (('path = "m.fmu"', 'path = "m.fmu"\ninterface = "ME"'), "model.interface", '"ME" is not me or cs'),
        (("name = \"k\"", "name = \"k\"\nscale = \"ln\""), "parameters[0].scale", '"ln" is not linear or log'),
        (("name = \"k\"", "name = \"k\"\nper_experiment = 1"), "parameters[0].per_experiment",
         "expected true or false"),
        (("[[outputs]]\nvariable = \"y\"\ncolumn = \"y\"\n", ""), "outputs", "missing"),
        (("upper = 3", "upper = 3\n[[experiments]]\nname = \"a\"\nrole = \"check\""), "experiments[0].role",
         '"check" is not fit or validation'),
        (("upper = 3", "upper = 3\n[[effects]]\nkind = \"viscous_damping\"\nparameters = { c = { start = 0 } }"),
         "effects[0].parameters.c.lower", "missing"),
        (("path = \"m.fmu\"", "path = \"absent.fmu\""), "model.path", "does not exist"),
        (("[data]\npath = \"d.csv\"", "[data]"), "data", "give the path of the measurements"),
        (("[data]", "[data\n"), "toml", "line"),
    ],
)
def test_a_bad_job_file_names_the_field(tmp_path: Path, edit: tuple[str, str], field: str, says: str) -> None:
    assert edit[0] in JOB
    e = error_of(tmp_path, JOB.replace(*edit, 1))
    assert e.field == field, str(e)
    assert says in e.message, str(e)
    assert str(e).startswith(f"{field}: ")


@pytest.mark.parametrize(
    ("data", "says"),
    [
        ("time,y\n0,1\n1,x\n", 'line 3: column "y": "x" is not a number'),
        ("time,y\n0,1\n1,1_000\n", 'line 3: column "y": "1_000" is not a number'),
        ("t,y\n0,1\n", 'line 1: no column named "time"; the closest: "t", "y"'),
        ("Time;TIME\n0;1\n", 'line 1: no column named "time"; did you mean "Time" or "TIME"?'),
        ("time,y,y\n0,1,1\n", 'line 1: column "y" appears twice'),
        ("time,y,z\n0,1,1\n1,1\n", 'line 3: 2 cells for 3 columns, column "z" is missing'),
        ("time,y\n", "no data rows"),
    ],
)
def test_bad_data_names_the_file_and_line(tmp_path: Path, data: str, says: str) -> None:
    e = error_of(tmp_path, JOB, data)
    assert e.field == "data"
    assert e.message == f"cannot read {tmp_path / 'd.csv'}: {says}"


def test_csv_cells_read_as_the_cli_reads_them(tmp_path: Path) -> None:
    path = tmp_path / "d.csv"
    path.write_bytes(b' y ,"time",z\r\n1.5,0,.5\n\n,1,+2e1\r\n NaN ,2,-inf\n')
    table = read_table(path, "time")
    assert table.time == [0.0, 1.0, 2.0]
    assert [name for name, _ in table.columns] == ["y", "z"]
    y, z = (values for _, values in table.columns)
    assert y[0] == 1.5 and math.isnan(y[1]) and math.isnan(y[2])
    assert z == [0.5, 20.0, -math.inf]


def test_a_csv_with_a_byte_order_mark_reads_as_the_cli_reads_it(tmp_path: Path) -> None:
    path = tmp_path / "d.csv"
    path.write_bytes(b"\xef\xbb\xbftime,y\n0,1.5\n1,2.5\n")
    table = read_table(path, "time")
    assert table.time == [0.0, 1.0]
    assert table.columns == [("y", [1.5, 2.5])]


def test_relative_paths_are_resolved_against_the_job_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    job = write_job(tmp_path)
    monkeypatch.chdir("/")
    spec = load_job(job)
    assert spec.model.path == tmp_path / "m.fmu"
    assert spec.data.path == tmp_path / "d.csv"
    request = build_request(job)
    assert request.spec.model_id == hashlib.sha256(b"not really an fmu").hexdigest()
    assert list(request.spec.data.time) == [0.0, 1.0]
    # A dict job resolves against base_dir.
    import tomllib

    as_dict = tomllib.loads(JOB)
    assert build_request(as_dict, base_dir=tmp_path) == request
    with pytest.raises(JobFileError, match="model.path: model file"):
        build_request(as_dict)


def test_set_from_fixes_an_earlier_optimum_unless_set_says_otherwise(tmp_path: Path) -> None:
    (tmp_path / "stage1").mkdir()
    (tmp_path / "stage1" / "result.json").write_text('{"x_opt": {"a": 0.25, "b": 3}, "f_opt": 1.0}')
    job = write_job(tmp_path, JOB + '[simulation]\nset_from = "stage1/result.json"\nset = { b = "fast" }\n')
    assert dict(build_request(job).spec.simulation.set) == {"a": "0.25", "b": "fast"}
    (tmp_path / "stage1" / "result.json").write_text('{"f_opt": 1.0}')
    with pytest.raises(JobFileError, match="simulation.set_from: cannot read .*no x_opt"):
        build_request(job)


def test_a_built_in_example_needs_the_fmucal_binary(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    job = write_job(tmp_path, JOB.replace('path = "m.fmu"', 'path = "example:furuta"'))
    monkeypatch.setenv("FMUCAL_BIN", "")
    monkeypatch.setenv("PATH", str(tmp_path))
    monkeypatch.setattr(binary, "_candidates", lambda: [tmp_path / "bin" / "fmucal"])
    with pytest.raises(JobFileError) as caught:
        build_request(job)
    assert caught.value.field == "model.path"
    assert "FMUCAL_BIN" in caught.value.message and "example:furuta" in caught.value.message


def test_an_unknown_example_is_named(tmp_path: Path, fmucal_bin: Path) -> None:
    job = write_job(tmp_path, JOB.replace('path = "m.fmu"', 'path = "example:no-such-model"'))
    with pytest.raises(JobFileError, match=r'model.path: no built-in example "no-such-model" \(examples: .*furuta'):
        build_request(job)


def test_mat_files_need_scipy_and_say_so(monkeypatch: pytest.MonkeyPatch) -> None:
    mat = REPO / "examples" / "furuta" / "FurutaData.mat"
    table = read_table(mat, "time")
    assert {"phi", "theta", "u"} <= {name for name, _ in table.columns}
    assert len(table.time) > 100
    monkeypatch.setitem(sys.modules, "scipy.io", None)
    with pytest.raises(JobFileError) as caught:
        read_table(mat, "time")
    assert caught.value.field == "data" and "needs SciPy" in caught.value.message


DATA = Path(__file__).resolve().parents[3] / "tests" / "data"


def test_csv_separators_decimal_commas_and_a_time_column_in_another_case() -> None:
    comma = read_table(DATA / "decay_Time.csv", "time")
    assert len(comma.time) == 21 and [n for n, _ in comma.columns] == ["x"]
    for name in ("decay_semicolon.csv", "decay_tab.csv"):
        assert read_table(DATA / name, "time") == comma, name


def test_v4_result_files_read_as_the_cli_reads_them() -> None:
    pytest.importorskip("scipy")
    for name in ("decay_dymola.mat", "decay_om.mat", "decay_normal.mat"):
        table = read_table(DATA / name, "time")
        assert [n for n, _ in table.columns] == ["k", "x", "der(x)", "xAlias", "minusX", "kAlias"], name
        values = dict(table.columns)
        assert table.time[0] == 0.0 and len(table.time) == 21
        assert values["x"][0] == 1.0 and values["xAlias"] == values["x"], name
        assert values["minusX"] == [-v for v in values["x"]], name
        assert values["kAlias"] == [-v for v in values["k"]] and abs(values["k"][5] - 1.7) < 1e-6, name
    om = dict(read_table(DATA / "decay_om.mat", "time").columns)
    assert om["x"][1] == math.exp(-1.7 * 0.1)
