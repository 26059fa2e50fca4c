"""Fixtures of the client's tests.

The tests that need a coordinator, the fmucal binary or the Rust conversion's output read them
from the environment, which ``tests/python_client.rs`` (``cargo test --release --test
python_client``) sets up: it starts a coordinator and workers, writes the ``SubmitJobRequest``
the Rust conversion makes of every job under ``examples/`` (and of a job that uses every
field), and runs this suite:

- ``FMUCAL_TEST_URL``, ``FMUCAL_TEST_TOKEN``: the coordinator and its client token;
- ``FMUCAL_BIN``: the fmucal binary (the CLI to compare with, and ``fmucal examples``);
- ``FMUCAL_TEST_RUST_REQUESTS``: the folder of the Rust requests and their ``manifest.json``.

A test whose variable is missing fails (it does not skip): run the suite through cargo.
"""

from __future__ import annotations

import json
import os
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from fmucal_client import Client

REPO = Path(__file__).resolve().parents[3]
"""The fmucal repository (this file is clients/python/tests/conftest.py)."""


def environment(name: str) -> str:
    """An environment variable the suite needs; the test fails without it."""
    value = os.environ.get(name)
    if not value:
        pytest.fail(f"{name} is not set: run this suite with `cargo test --release --test python_client`")
    return value


@pytest.fixture(scope="session")
def coordinator_url() -> str:
    """The URL of the test coordinator."""
    return environment("FMUCAL_TEST_URL")


@pytest.fixture(scope="session")
def token() -> str:
    """The test coordinator's client token."""
    return environment("FMUCAL_TEST_TOKEN")


@pytest.fixture(scope="session")
def fmucal_bin() -> Path:
    """The fmucal binary."""
    path = Path(environment("FMUCAL_BIN"))
    assert path.is_file(), f"FMUCAL_BIN={path} is not a file"
    return path


@pytest.fixture
def client(coordinator_url: str, token: str, fmucal_bin: Path) -> Iterator[Client]:
    """A client of the test coordinator (``fmucal_bin`` makes ``example:NAME`` resolvable)."""
    with Client(coordinator_url, token=token) as c:
        yield c


def rust_manifest() -> list[dict[str, Any]] | None:
    """The Rust requests' manifest: ``name`` (the job's path in the repository, or a label),
    ``toml`` (the job file to convert) and ``request`` (the serialized SubmitJobRequest)."""
    folder = os.environ.get("FMUCAL_TEST_RUST_REQUESTS")
    if not folder:
        return None
    return json.loads((Path(folder) / "manifest.json").read_text(encoding="utf-8"))


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    """Parametrizes ``rust_case`` with every entry of the Rust requests' manifest."""
    if "rust_case" in metafunc.fixturenames:
        cases = rust_manifest()
        if cases is None:
            metafunc.parametrize("rust_case", [None], ids=["FMUCAL_TEST_RUST_REQUESTS-missing"])
        else:
            metafunc.parametrize("rust_case", cases, ids=[c["name"] for c in cases])


FURUTA = REPO / "examples" / "furuta" / "job.toml"


@pytest.fixture(scope="session")
def cli_furuta(tmp_path_factory: pytest.TempPathFactory, fmucal_bin: Path) -> tuple[dict[str, Any], Path]:
    """``fmucal calibrate examples/furuta/job.toml``'s ``result.json`` and ``--out`` folder: what
    every local run of that job from Python must give, to the last bit."""
    out = tmp_path_factory.mktemp("cli") / "out"
    done = subprocess.run([str(fmucal_bin), "calibrate", str(FURUTA), "--out", str(out)],
                          capture_output=True, text=True, timeout=600, check=False)
    assert done.returncode == 0, done.stderr
    return json.loads((out / "result.json").read_text()), out
