"""The package's build: the committed gRPC stubs describe the repository's proto as it is now,
the wheel's configuration carries the fmucal binary, and the build backend sends cargo's output
outside the checkout."""

from __future__ import annotations

import importlib.util
import re
import sys
import tomllib
from pathlib import Path
from typing import Any

import pytest

from conftest import REPO
from fmucal_client.proto import pb, pb_grpc

HERE = REPO / "clients" / "python"
PROTO = REPO / "proto" / "fmucal" / "v1" / "fmucal.proto"


def compiled_proto(tmp_path: Path) -> bytes:
    """The proto compiled now, as a serialized FileDescriptorProto under the stubs' virtual path."""
    protoc = pytest.importorskip("grpc_tools.protoc", reason="comparing the stubs needs grpcio-tools")
    out = tmp_path / "descriptor.pb"
    status = protoc.main(["grpc_tools.protoc", f"--proto_path=fmucal_client/_pb={PROTO.parent}",
                          f"--descriptor_set_out={out}", f"fmucal_client/_pb/{PROTO.name}"])
    assert status == 0, f"grpc_tools.protoc failed on {PROTO}"
    from google.protobuf import descriptor_pb2

    files = descriptor_pb2.FileDescriptorSet.FromString(out.read_bytes()).file
    assert len(files) == 1

    # The Python generator leaves out the JSON names protoc derives from the field names.
    def without_json_names(messages: Any) -> None:
        for m in messages:
            for f in m.field:
                f.ClearField("json_name")
            without_json_names(m.nested_type)

    without_json_names(files[0].message_type)
    return files[0].SerializeToString(deterministic=True)


def test_the_committed_stubs_describe_the_proto_as_it_is(tmp_path: Path) -> None:
    from google.protobuf import descriptor_pb2

    # The file descriptor protoc wrote into the committed module, as protoc compiles it now.
    committed = descriptor_pb2.FileDescriptorProto.FromString(pb.DESCRIPTOR.serialized_pb)
    assert committed.SerializeToString(deterministic=True) == compiled_proto(tmp_path), (
        "src/fmucal_client/_pb/ is out of date with proto/fmucal/v1/fmucal.proto: run "
        "`python clients/python/tools/generate_pb.py` and commit the result"
    )


def test_the_stubs_hold_every_message_and_rpc_of_the_proto() -> None:
    text = PROTO.read_text()
    messages = set(re.findall(r"^message (\w+)", text, re.MULTILINE))
    assert len(messages) > 30
    assert messages == set(pb.DESCRIPTOR.message_types_by_name)
    rpcs = re.findall(r"^\s*rpc (\w+)\(", text, re.MULTILINE)
    calibration = pb.DESCRIPTOR.services_by_name["Calibration"]
    assert {m.name for m in calibration.methods} <= set(rpcs)
    assert hasattr(pb_grpc, "CalibrationStub")


def test_the_wheel_carries_the_fmucal_binary_of_the_workspace() -> None:
    project = tomllib.loads((HERE / "pyproject.toml").read_text())
    maturin = project["tool"]["maturin"]
    assert maturin["bindings"] == "bin"
    manifest = (HERE / maturin["manifest-path"]).resolve()
    assert manifest == REPO / "Cargo.toml"
    cargo = tomllib.loads(manifest.read_text())
    assert cargo["package"]["name"] == "fmucal"
    assert [b["name"] for b in cargo["bin"]] == ["fmucal"]
    assert project["project"]["version"] == cargo["workspace"]["package"]["version"]
    assert project["build-system"]["build-backend"] == "fmucal_build"


def load_backend(monkeypatch: pytest.MonkeyPatch) -> object:
    pytest.importorskip("maturin", reason="the build backend wraps maturin")
    monkeypatch.setattr(sys, "dont_write_bytecode", sys.dont_write_bytecode)
    spec = importlib.util.spec_from_file_location("fmucal_build_test", HERE / "build_backend" / "fmucal_build.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_cargo_output_goes_to_the_declared_folder_outside_the_checkout(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    backend = load_backend(monkeypatch)
    for var in ("FMUCAL_PYTHON_TARGET_DIR", "CARGO_TARGET_DIR"):
        monkeypatch.delenv(var, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    assert backend.target_dir() == (tmp_path / "cache" / "fmucal" / "python-target", False)  # type: ignore[attr-defined]
    monkeypatch.setenv("CARGO_TARGET_DIR", str(tmp_path / "cargo"))
    assert backend.target_dir() == (tmp_path / "cargo", False)  # type: ignore[attr-defined]
    monkeypatch.setenv("FMUCAL_PYTHON_TARGET_DIR", str(tmp_path / "mine"))
    assert backend.target_dir() == (tmp_path / "mine", False)  # type: ignore[attr-defined]
    # A cache folder that cannot be made: a temporary folder, removed after the build.
    for var in ("FMUCAL_PYTHON_TARGET_DIR", "CARGO_TARGET_DIR"):
        monkeypatch.delenv(var)
    (tmp_path / "file").write_text("")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "file"))
    folder, temporary = backend.target_dir()  # type: ignore[attr-defined]
    assert temporary and not str(folder).startswith(str(REPO))
    folder.rmdir()
