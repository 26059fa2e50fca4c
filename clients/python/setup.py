"""Build hook of fmucal_client: generates the gRPC stubs from the repository's protocol.

The protocol lives once, in ``proto/fmucal/v1/fmucal.proto`` of the fmucal repository (two
folders above this file). Before setuptools copies the package, ``grpc_tools.protoc`` compiles
that file into ``src/fmucal_client/_pb/`` (``fmucal_pb2.py``, ``fmucal_pb2_grpc.py`` and their
``.pyi``). The proto is mapped to the virtual path ``fmucal_client/_pb/``, so the generated
service module imports its messages from inside this package. The generated files are not
committed (see ``.gitignore``); they are written to a temporary folder first and moved into
place one by one, so two builds at once never leave half a file.

``FMUCAL_PROTO_DIR`` may name another ``proto/`` folder (a checkout elsewhere).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent
PROTO_FILE = Path("fmucal") / "v1" / "fmucal.proto"
STUBS_DIR = HERE / "src" / "fmucal_client" / "_pb"
VIRTUAL_DIR = "fmucal_client/_pb"


def proto_file() -> Path:
    """The repository's proto file, or a build error saying where it was looked for."""
    root = Path(os.environ.get("FMUCAL_PROTO_DIR") or HERE.parent.parent / "proto")
    path = root / PROTO_FILE
    if not path.is_file():
        raise SystemExit(
            f"fmucal_client: cannot generate the gRPC stubs: {path} does not exist. Build the client "
            "inside an fmucal checkout (pip install clients/python), or set FMUCAL_PROTO_DIR to the "
            "checkout's proto/ folder."
        )
    return path


def generate_stubs() -> None:
    """Runs grpc_tools.protoc on the proto file and moves its output into ``_pb/``."""
    try:
        from grpc_tools import protoc
    except ImportError as e:
        raise SystemExit(
            "fmucal_client: building needs grpcio-tools, which generates the gRPC stubs "
            "(pip install grpcio-tools, or build without --no-build-isolation)"
        ) from e
    source = proto_file()
    STUBS_DIR.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix=".tmp-", dir=STUBS_DIR) as tmp:
        status = protoc.main(
            [
                "grpc_tools.protoc",
                f"--proto_path={VIRTUAL_DIR}={source.parent}",
                f"--python_out={tmp}",
                f"--pyi_out={tmp}",
                f"--grpc_python_out={tmp}",
                f"{VIRTUAL_DIR}/{source.name}",
            ]
        )
        if status != 0:
            raise SystemExit(f"fmucal_client: grpc_tools.protoc failed on {source} (exit status {status})")
        generated = Path(tmp) / VIRTUAL_DIR
        for path in sorted(generated.iterdir()):
            os.replace(path, STUBS_DIR / path.name)


class BuildPyWithStubs(build_py):  # type: ignore[misc]
    """``build_py`` that generates the stubs first (regular and editable installs)."""

    def run(self) -> None:
        generate_stubs()
        super().run()


setup(cmdclass={"build_py": BuildPyWithStubs})
