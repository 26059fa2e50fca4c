"""The PEP 517 build backend of fmucal-client: maturin, with cargo's output outside the checkout.

maturin builds the wheel: the ``fmucal`` binary (the repository's root package, as
``bindings = "bin"``; pip installs it into the environment's ``bin/``, as ruff and uv ship
theirs) and the Python package ``src/fmucal_client``. Left alone, cargo would write its output
to the workspace's ``target/``, inside the checkout; this wrapper declares another folder
before handing every hook to maturin, so that installing writes nothing under the checkout:

1. ``FMUCAL_PYTHON_TARGET_DIR``, if set;
2. else ``CARGO_TARGET_DIR``, if set (the caller's own choice for every cargo build);
3. else ``$XDG_CACHE_HOME/fmucal/python-target`` (``~/.cache/fmucal/python-target``), kept
   between installs so a second install only relinks;
4. else, when that folder cannot be created, a temporary folder, removed after the build.

Python writes the bytecode of an imported module beside it (``__pycache__/``), and pip imports
this module from the checkout: it turns that off for what it imports itself, and removes the
one file its own import wrote.
"""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path

sys.dont_write_bytecode = True


def _forget_own_bytecode() -> None:
    """Removes the ``.pyc`` this module's import just wrote, and its folder if that is empty."""
    try:
        cached = Path(importlib.util.cache_from_source(__file__))
        cached.unlink(missing_ok=True)
        cached.parent.rmdir()
    except (OSError, NotImplementedError, ValueError):
        pass  # another build's file, or a folder that holds more: not ours to remove


_forget_own_bytecode()

import maturin  # noqa: E402 (after turning bytecode off)

TARGET_ENV = "FMUCAL_PYTHON_TARGET_DIR"
"""Names cargo's output folder for this build (an absolute path)."""


def target_dir() -> tuple[Path, bool]:
    """Cargo's output folder, and whether it is a temporary one to remove after the build."""
    for var in (TARGET_ENV, "CARGO_TARGET_DIR"):
        if os.environ.get(var):
            return Path(os.environ[var]).expanduser().absolute(), False
    cache = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    folder = cache / "fmucal" / "python-target"
    try:
        folder.mkdir(parents=True, exist_ok=True)
        return folder, False
    except OSError:
        import tempfile

        return Path(tempfile.mkdtemp(prefix="fmucal-python-target-")), True


def _with_target(hook, *args, **kwargs):  # type: ignore[no-untyped-def]
    folder, temporary = target_dir()
    os.environ["CARGO_TARGET_DIR"] = str(folder)
    print(f"fmucal-client: cargo's output goes to {folder}", file=sys.stderr, flush=True)
    try:
        return hook(*args, **kwargs)
    finally:
        if temporary:
            import shutil

            shutil.rmtree(folder, ignore_errors=True)


def get_requires_for_build_wheel(config_settings=None):  # type: ignore[no-untyped-def]
    return maturin.get_requires_for_build_wheel(config_settings)


def get_requires_for_build_sdist(config_settings=None):  # type: ignore[no-untyped-def]
    return maturin.get_requires_for_build_sdist(config_settings)


def prepare_metadata_for_build_wheel(metadata_directory, config_settings=None):  # type: ignore[no-untyped-def]
    return _with_target(maturin.prepare_metadata_for_build_wheel, metadata_directory, config_settings)


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):  # type: ignore[no-untyped-def]
    return _with_target(maturin.build_wheel, wheel_directory, config_settings, metadata_directory)


def build_sdist(sdist_directory, config_settings=None):  # type: ignore[no-untyped-def]
    return _with_target(maturin.build_sdist, sdist_directory, config_settings)
