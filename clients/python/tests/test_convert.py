"""The TOML → SubmitJobRequest conversion equals the Rust CLI's (``job_to_proto``), byte for
byte, for every job file under ``examples/`` and for a job that uses every field; Rust's
requests are written by ``tests/python_client.rs``."""

from __future__ import annotations

import difflib
import math
from pathlib import Path
from typing import Any

import pytest
from google.protobuf import text_format

from conftest import REPO, rust_manifest
from fmucal_client import build_request
from fmucal_client.convert import float_text
from fmucal_client.proto import pb


def readable_diff(rust: pb.SubmitJobRequest, python: pb.SubmitJobRequest) -> str:
    """The lines that differ between the two messages' text forms."""
    lines = [text_format.MessageToString(m).splitlines() for m in (rust, python)]
    diff = difflib.unified_diff(*lines, "rust", "python", lineterm="", n=2)
    return "\n".join(list(diff)[:80])


def test_request_equals_the_rust_conversion(rust_case: dict[str, Any] | None, fmucal_bin: Path) -> None:
    assert rust_case is not None, "FMUCAL_TEST_RUST_REQUESTS is not set: run through cargo"
    rust = pb.SubmitJobRequest.FromString(Path(rust_case["request"]).read_bytes())
    # The model id is the SHA-256 of the model Python finds (example:NAME via `fmucal examples`),
    # so it matches Rust's only if both found the same bytes.
    python = build_request(rust_case["toml"])
    assert rust.spec.model_id and python.spec.model_id == rust.spec.model_id
    # Maps are written in key order on both sides; floats compare by their bits (NaN included).
    same = rust.SerializeToString(deterministic=True) == python.SerializeToString(deterministic=True)
    assert same, f"{rust_case['name']}: the requests differ:\n{readable_diff(rust, python)}"


def test_the_manifest_covers_every_job_under_examples() -> None:
    cases = rust_manifest()
    assert cases is not None, "FMUCAL_TEST_RUST_REQUESTS is not set: run through cargo"
    jobs = sorted(str(p.relative_to(REPO)) for p in (REPO / "examples").rglob("*.toml"))
    assert len(jobs) >= 6
    assert set(jobs) <= {c["name"] for c in cases}
    # The job that uses every field is there too.
    assert any(c["name"] == "every-field" for c in cases)


@pytest.mark.parametrize(
    ("value", "text"),
    [
        (1.0, "1"),
        (0.1, "0.1"),
        (9.81, "9.81"),
        (1e-7, "0.0000001"),
        (1e21, "1000000000000000000000"),
        (-2.5e-3, "-0.0025"),
        (-0.0, "-0"),
        (math.nan, "NaN"),
        (math.inf, "inf"),
        (-math.inf, "-inf"),
    ],
)
def test_numbers_are_written_as_rust_displays_them(value: float, text: str) -> None:
    assert float_text(value) == text
