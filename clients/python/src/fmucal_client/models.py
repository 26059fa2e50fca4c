"""Where a job's model is: a ``.fmu`` file, or ``example:NAME`` for a model built into fmucal.

The built-in examples live inside the ``fmucal`` binary, which writes them to its cache folder
and lists their paths (``fmucal examples``). Python cannot read them any other way, so an
``example:NAME`` model is found by running that command with the binary
:mod:`fmucal_client.binary` finds (the one the package installed, unless ``FMUCAL_BIN`` names
another). Without one, such a job is refused naming ``model.path``; give the ``.fmu`` path
instead. A model's id on a coordinator is the SHA-256 of its bytes.
"""

from __future__ import annotations

import functools
import hashlib
import os
import subprocess
from pathlib import Path

from . import binary
from .errors import JobFileError
from .job import quote

EXAMPLE_PREFIX = "example:"


def fmucal_binary() -> str | None:
    """The fmucal executable to ask for examples (:func:`fmucal_client.binary.find`)."""
    return binary.find()


@functools.cache
def _examples(binary: str) -> dict[str, Path]:
    """The built-in examples ``binary`` lists (it writes them out first), by name."""
    try:
        done = subprocess.run([binary, "examples"], capture_output=True, text=True, timeout=120, check=False)
    except OSError as e:
        raise JobFileError("model.path", f"cannot run {binary} examples to find the built-in examples: {e}") from e
    if done.returncode != 0:
        why = done.stderr.strip() or f"exit status {done.returncode}"
        raise JobFileError("model.path", f"{binary} examples failed: {why}")
    listed = {}
    for line in done.stdout.splitlines():
        name, _, path = line.strip().partition(" ")
        if name and path.strip():
            listed[name] = Path(path.strip())
    return listed


def example_path(name: str) -> Path:
    """The ``.fmu`` of built-in example ``name``, as ``fmucal examples`` lists it.

    Raises:
        JobFileError: naming ``model.path`` if no fmucal binary is found or it has no such example.
    """
    binary = fmucal_binary()
    if binary is None:
        raise JobFileError(
            "model.path",
            f"{quote(EXAMPLE_PREFIX + name)} is a model built into the fmucal binary, which the Python client "
            "runs (`fmucal examples`) to find it: install the package with its binary (pip install "
            "./clients/python), set FMUCAL_BIN, or give the path of the .fmu",
        )
    listed = _examples(binary)
    if name not in listed:
        raise JobFileError("model.path", f"no built-in example {quote(name)} (examples: {', '.join(listed)})")
    return listed[name]


def resolve_model(path: str | os.PathLike[str]) -> Path:
    """The file of a job's model: ``example:NAME`` through :func:`example_path`, else the path,
    which must be a file.

    Raises:
        JobFileError: naming ``model.path``.
    """
    text = str(path)
    if text.startswith(EXAMPLE_PREFIX):
        return example_path(text[len(EXAMPLE_PREFIX):])
    file = Path(path)
    if not file.is_file():
        raise JobFileError("model.path", f"model file {file} does not exist")
    return file


def model_id(path: Path) -> str:
    """The id a coordinator gives the model at ``path``: the hex SHA-256 of its bytes."""
    digest = hashlib.sha256()
    with path.open("rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def resolve_model_argument(model: str | os.PathLike[str]) -> Path:
    """A model given as the CLI's MODEL argument (``fmucal inspect MODEL``): an existing file,
    else ``example:NAME`` or a bare example name.

    Raises:
        JobFileError: naming ``model.path`` if it is neither.
    """
    text = str(model)
    if not text.startswith(EXAMPLE_PREFIX) and Path(model).exists():
        return Path(model)
    name = text.removeprefix(EXAMPLE_PREFIX)
    binary = fmucal_binary()
    if binary is not None and name in _examples(binary):
        return _examples(binary)[name]
    if text.startswith(EXAMPLE_PREFIX):
        return example_path(name)
    raise JobFileError("model.path", f"no such file {quote(text)}, and no built-in example of that name")
