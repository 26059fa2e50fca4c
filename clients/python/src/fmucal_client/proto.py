"""The generated ``fmucal.v1`` messages (``pb``) and service stubs (``pb_grpc``).

They are generated from ``proto/fmucal/v1/fmucal.proto`` when the package is built
(``setup.py``); a source tree that was never built has none, and importing says so.
"""

from __future__ import annotations

try:
    from ._pb import fmucal_pb2 as pb
    from ._pb import fmucal_pb2_grpc as pb_grpc
except ImportError as e:  # pragma: no cover - only in an unbuilt source tree
    raise ImportError(
        "fmucal_client's gRPC stubs are missing: they are generated from proto/fmucal/v1/fmucal.proto when "
        f"the package is built; install it with `pip install clients/python` from an fmucal checkout ({e})"
    ) from e

__all__ = ["pb", "pb_grpc"]
