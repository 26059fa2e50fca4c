"""The package's build: the stubs come from the repository's proto, and a missing proto is a
clear build error."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

from conftest import REPO
from fmucal_client.proto import pb, pb_grpc

PROTO = REPO / "proto" / "fmucal" / "v1" / "fmucal.proto"


def test_the_installed_stubs_hold_every_message_and_rpc_of_the_proto() -> None:
    text = PROTO.read_text()
    messages = set(re.findall(r"^message (\w+)", text, re.MULTILINE))
    assert len(messages) > 30
    assert messages == set(pb.DESCRIPTOR.message_types_by_name)
    rpcs = re.findall(r"^\s*rpc (\w+)\(", text, re.MULTILINE)
    calibration = pb.DESCRIPTOR.services_by_name["Calibration"]
    assert {m.name for m in calibration.methods} <= set(rpcs)
    assert hasattr(pb_grpc, "CalibrationStub")


def test_a_missing_proto_fails_the_build_naming_the_path(tmp_path: Path) -> None:
    build = subprocess.run(
        [sys.executable, "setup.py", "--quiet", "build_py", "--build-lib", str(tmp_path / "lib")],
        cwd=REPO / "clients" / "python",
        env={**os.environ, "FMUCAL_PROTO_DIR": str(tmp_path / "nowhere")},
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert build.returncode != 0
    assert f"{tmp_path / 'nowhere' / 'fmucal' / 'v1' / 'fmucal.proto'} does not exist" in build.stderr, build.stderr
    assert not (tmp_path / "lib").exists()
