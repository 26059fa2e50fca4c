#!/usr/bin/env python3
"""Regenerates the package's gRPC stubs (``src/fmucal_client/_pb/``) from the repository's
``proto/fmucal/v1/fmucal.proto`` with ``grpc_tools.protoc``.

The stubs are committed, so that installing the package generates nothing and reads nothing
outside ``clients/python``. ``tests/test_build.py`` checks that the committed stubs describe
the proto as it is now (the same ``FileDescriptorProto``); after changing the proto, run

    python clients/python/tools/generate_pb.py

with the ``grpcio-tools`` that ``tests/fmpy/requirements.txt`` pins, and commit the result.
The proto is mapped to the virtual path ``fmucal_client/_pb/``, so the generated service
module imports its messages from inside the package.
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent.parent
PROTO = HERE.parent.parent / "proto" / "fmucal" / "v1" / "fmucal.proto"
STUBS = HERE / "src" / "fmucal_client" / "_pb"
VIRTUAL_DIR = "fmucal_client/_pb"


def main() -> int:
    from grpc_tools import protoc

    with tempfile.TemporaryDirectory() as tmp:
        status = protoc.main(
            [
                "grpc_tools.protoc",
                f"--proto_path={VIRTUAL_DIR}={PROTO.parent}",
                f"--python_out={tmp}",
                f"--pyi_out={tmp}",
                f"--grpc_python_out={tmp}",
                f"{VIRTUAL_DIR}/{PROTO.name}",
            ]
        )
        if status != 0:
            print(f"grpc_tools.protoc failed on {PROTO} (exit status {status})", file=sys.stderr)
            return 1
        for path in sorted((Path(tmp) / VIRTUAL_DIR).iterdir()):
            os.replace(path, STUBS / path.name)
            print(f"wrote {STUBS / path.name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
