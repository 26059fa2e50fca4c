"""The examples of ``examples/python`` run: the quickstart script, and the notebook executed
with nbclient (no cell may fail, and its ``x_opt`` cell shows the CLI's optimum to the last
bit)."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from conftest import REPO

EXAMPLES = REPO / "examples" / "python"


def test_the_quickstart_script_prints_the_cli_optimum(
    tmp_path: Path, cli_furuta: tuple[dict[str, Any], Path]
) -> None:
    expected, _ = cli_furuta
    done = subprocess.run([sys.executable, str(EXAMPLES / "quickstart.py")], cwd=tmp_path, capture_output=True,
                          text=True, timeout=600, check=False, env={**os.environ, "MPLBACKEND": "Agg"})
    assert done.returncode == 0, done.stdout + done.stderr
    line = next(line for line in done.stdout.splitlines() if line.startswith("x_opt = "))
    assert ast.literal_eval(line.removeprefix("x_opt = ")) == expected["x_opt"]
    assert "standard error" in done.stdout
    assert (tmp_path / "furuta_fit.png").read_bytes().startswith(b"\x89PNG")


def test_the_notebook_runs_and_shows_the_cli_optimum(
    cli_furuta: tuple[dict[str, Any], Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    expected, _ = cli_furuta
    monkeypatch.delenv("MPLBACKEND", raising=False)  # the kernel's own inline backend, as in Jupyter
    notebook = nbformat.read(EXAMPLES / "furuta.ipynb", as_version=4)
    # Run from the notebook's folder, as Jupyter would; any failing cell raises.
    nbclient.NotebookClient(notebook, timeout=600, kernel_name="python3",
                            resources={"metadata": {"path": str(EXAMPLES)}}).execute()
    cells = [c for c in notebook.cells if "x_opt" in c.get("metadata", {}).get("tags", [])]
    assert len(cells) == 1
    shown = [o for o in cells[0].outputs if o.get("output_type") == "execute_result"]
    assert ast.literal_eval(shown[0]["data"]["text/plain"]) == expected["x_opt"]
    # Every cell ran, and the plot cell drew a PNG.
    code = [c for c in notebook.cells if c.cell_type == "code"]
    assert all(c.execution_count for c in code)
    assert any("image/png" in o.get("data", {}) for c in code for o in c.outputs)
