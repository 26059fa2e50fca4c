"""Runs the ``fmucal`` binary as a child process: its progress lines go to a callback as they
come, its one-line ``error: ...`` becomes a :class:`~fmucal_client.errors.CommandError`, and
Ctrl-C (KeyboardInterrupt) stops it as Ctrl-C in a terminal would (SIGINT: a calibration
cancels its job and writes its best point so far) before the interrupt goes on.

On Linux the child gets SIGTERM when the Python process dies, so that no calibration (and none
of its worker processes, which die with it) outlives the notebook kernel that started it.
"""

from __future__ import annotations

import json
import os
import queue
import signal
import subprocess
import sys
import threading
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .errors import CommandError

INTERRUPT_GRACE_S = 30.0
"""How long an interrupted run may take to write its best point before it is killed."""


@dataclass(frozen=True)
class Completed:
    """A run that exited with status 0: what it printed."""

    stdout: str
    stderr: str


def _die_with_parent() -> None:  # pragma: no cover - runs in the child
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        pr_set_pdeathsig = 1
        libc.prctl(pr_set_pdeathsig, signal.SIGTERM, 0, 0, 0)
    except (OSError, AttributeError):
        pass


def _read(stream: Any, name: str, into: queue.Queue[tuple[str, str | None]]) -> None:
    for line in stream:
        into.put((name, line))
    into.put((name, None))


def run(
    binary: str,
    args: Sequence[str | os.PathLike[str]],
    *,
    on_progress: Callable[[dict[str, Any]], None] | None = None,
    on_status: Callable[[str], None] | None = None,
    env: Mapping[str, str] | None = None,
    cwd: str | os.PathLike[str] | None = None,
) -> Completed:
    """Runs ``binary args`` to its end.

    A stderr line that is a JSON object with a ``progress`` member goes to ``on_progress``;
    any other stderr line to ``on_status`` (without its newline).

    Raises:
        CommandError: the binary exited with another status than 0; ``field`` names the job's
            field when its ``error:`` line starts with one.
        KeyboardInterrupt: after the binary stopped, if Ctrl-C came while it ran.
    """
    command = [str(binary), *(os.fspath(a) for a in args)]
    child_env = {**os.environ, **(env or {})}
    linux = sys.platform.startswith("linux")
    try:
        proc = subprocess.Popen(
            command,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            encoding="utf-8",
            errors="replace",
            env=child_env,
            cwd=cwd,
            preexec_fn=_die_with_parent if linux else None,  # noqa: PLW1509 (no threads of ours run yet)
        )
    except OSError as e:
        raise CommandError(f"cannot run {binary}: {e}", command=command) from e
    lines: queue.Queue[tuple[str, str | None]] = queue.Queue()
    readers = [
        threading.Thread(target=_read, args=(proc.stdout, "stdout", lines), daemon=True),
        threading.Thread(target=_read, args=(proc.stderr, "stderr", lines), daemon=True),
    ]
    for r in readers:
        r.start()
    out: list[str] = []
    err: list[str] = []
    open_streams = 2
    interrupted = False
    while open_streams:
        try:
            name, line = lines.get(timeout=0.1)
        except queue.Empty:
            continue
        except KeyboardInterrupt:
            interrupted = True
            _stop(proc)
            continue
        if line is None:
            open_streams -= 1
            continue
        if name == "stdout":
            out.append(line)
            continue
        progress = _progress(line)
        if progress is not None:
            if on_progress is not None:
                on_progress(progress)
            continue
        err.append(line)
        if on_status is not None:
            on_status(line.rstrip("\n"))
    try:
        code = proc.wait()
    except KeyboardInterrupt:
        interrupted = True
        _stop(proc)
        code = proc.wait()
    for r in readers:
        r.join()
    stdout, stderr = "".join(out), "".join(err)
    if interrupted or code == 130:
        raise KeyboardInterrupt
    if code != 0:
        raise CommandError.from_stderr(stderr, code, command)
    return Completed(stdout, stderr)


def _stop(proc: subprocess.Popen[str]) -> None:
    """SIGINT, then SIGKILL if the child is still there after the grace time."""
    if proc.poll() is not None:
        return
    proc.send_signal(signal.SIGINT)
    try:
        proc.wait(timeout=INTERRUPT_GRACE_S)
    except subprocess.TimeoutExpired:
        proc.kill()


def _progress(line: str) -> dict[str, Any] | None:
    if not line.startswith('{"progress"'):
        return None
    try:
        event = json.loads(line)
    except ValueError:
        return None
    progress = event.get("progress") if isinstance(event, dict) else None
    return progress if isinstance(progress, dict) else None


def absolute(path: str | os.PathLike[str]) -> Path:
    """``path`` made absolute against the current folder (as the binary, run here, would)."""
    return Path(path).expanduser().absolute()
