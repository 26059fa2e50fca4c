"""A TOML writer for job tables (Python reads TOML, but writes none): the job a local run
hands to the ``fmucal`` binary when it was given as a dict or a :class:`~fmucal_client.JobSpec`.

Tables become ``[name]`` sections, lists of tables ``[[name]]`` entries, and anything deeper is
written inline; strings are basic strings with TOML's escapes, floats keep every bit
(``repr``), and infinities and NaN are ``inf``, ``-inf`` and ``nan``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from typing import Any

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def key(name: str) -> str:
    """A key, bare when TOML allows it, else quoted."""
    return name if _BARE_KEY.match(name) else string(name)


def string(text: str) -> str:
    """A TOML basic string."""
    out = ['"']
    for ch in text:
        code = ord(ch)
        if ch == '"':
            out.append('\\"')
        elif ch == "\\":
            out.append("\\\\")
        elif ch == "\n":
            out.append("\\n")
        elif ch == "\t":
            out.append("\\t")
        elif ch == "\r":
            out.append("\\r")
        elif code < 0x20 or code == 0x7F:
            out.append(f"\\u{code:04x}")
        else:
            out.append(ch)
    out.append('"')
    return "".join(out)


def value(v: Any) -> str:
    """A value written inline."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        text = repr(v)
        return text if any(c in text for c in ".eEn") else text + ".0"
    if isinstance(v, str):
        return string(v)
    if isinstance(v, Mapping):
        return "{ " + ", ".join(f"{key(str(k))} = {value(x)}" for k, x in v.items()) + " }" if v else "{}"
    if isinstance(v, Sequence):
        return "[" + ", ".join(value(x) for x in v) + "]"
    if hasattr(v, "__fspath__"):
        return string(str(v))
    raise TypeError(f"cannot write {type(v).__name__} {v!r} as TOML")


def _is_tables(v: Any) -> bool:
    return isinstance(v, Sequence) and not isinstance(v, str) and bool(v) and all(isinstance(x, Mapping) for x in v)


def dumps(table: Mapping[str, Any]) -> str:
    """The TOML text of ``table`` (a job: top-level tables and lists of tables)."""
    lines = []
    sections = []
    for k, v in table.items():
        if v is None:
            continue
        if isinstance(v, Mapping):
            sections.append((f"[{key(k)}]", v))
        elif _is_tables(v):
            sections.extend((f"[[{key(k)}]]", item) for item in v)
        else:
            lines.append(f"{key(k)} = {value(v)}")
    for header, body in sections:
        lines.append("")
        lines.append(header)
        lines.extend(f"{key(str(k))} = {value(x)}" for k, x in body.items() if x is not None)
    return "\n".join(lines) + "\n"
