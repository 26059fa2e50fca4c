"""gRPC stubs of ``fmucal.v1``, generated from ``proto/fmucal/v1/fmucal.proto`` by
``tools/generate_pb.py`` (grpcio-tools) and committed, so that installing generates nothing."""
