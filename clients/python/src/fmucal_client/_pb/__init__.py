"""gRPC stubs of ``fmucal.v1``, generated from ``proto/fmucal/v1/fmucal.proto`` when the package is
built (see ``setup.py``); the generated modules are not in version control."""
