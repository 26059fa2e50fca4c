"""The ``fmucal`` binary this package runs for local work (calibrate, diagnose, simulate, and the
built-in ``example:NAME`` models).

The wheel carries the binary (maturin's ``bindings = "bin"``), which pip installs into the
environment's scripts folder (``bin/``) beside ``python``, as ruff and uv do theirs. It is
looked for in this order:

1. ``FMUCAL_BIN``, if set (a binary built by hand: ``target/release/fmucal``);
2. the scripts folder of this environment, then of the user scheme (``pip install --user``);
3. ``bin/`` beside the package's folder (``pip install --target DIR``);
4. ``fmucal`` on ``PATH``.
"""

from __future__ import annotations

import os
import shutil
import sys
import sysconfig
from pathlib import Path

from .errors import ConfigurationError

NAME = "fmucal" + (".exe" if sys.platform == "win32" else "")


def _candidates() -> list[Path]:
    folders = []
    for scheme in (None, f"{os.name}_user"):
        try:
            path = sysconfig.get_path("scripts") if scheme is None else sysconfig.get_path("scripts", scheme)
        except KeyError:
            continue
        if path:
            folders.append(Path(path))
    folders.append(Path(__file__).resolve().parent.parent / "bin")
    return [folder / NAME for folder in folders]


def find() -> str | None:
    """The fmucal binary to run, or ``None`` if there is none (see the module's order)."""
    given = os.environ.get("FMUCAL_BIN")
    if given:
        return given
    for path in _candidates():
        if path.is_file() and os.access(path, os.X_OK):
            return str(path)
    return shutil.which("fmucal")


def require() -> str:
    """The fmucal binary to run.

    Raises:
        ConfigurationError: there is none; the message says where it was looked for.
    """
    found = find()
    if found is None:
        looked = ", ".join(str(p) for p in _candidates())
        raise ConfigurationError(
            f"no fmucal binary: looked at FMUCAL_BIN, {looked} and PATH. Install the package with "
            "`pip install ./clients/python` (its wheel carries the binary), or set FMUCAL_BIN to a built "
            "fmucal (cargo build --release: target/release/fmucal)"
        )
    if not Path(found).is_file() and shutil.which(found) is None:
        raise ConfigurationError(f"FMUCAL_BIN={found} is not a file")
    return found


__all__ = ["find", "require"]
