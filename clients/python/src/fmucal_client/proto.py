"""The generated ``fmucal.v1`` messages (``pb``) and service stubs (``pb_grpc``).

They are generated from ``proto/fmucal/v1/fmucal.proto`` by ``tools/generate_pb.py`` and
committed; ``tests/test_build.py`` checks that they still describe the proto.
"""

from __future__ import annotations

from ._pb import fmucal_pb2 as pb
from ._pb import fmucal_pb2_grpc as pb_grpc

__all__ = ["pb", "pb_grpc"]
