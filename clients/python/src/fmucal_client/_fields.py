"""Typed reading of one TOML table, with every error naming its field as the CLI does.

A :class:`Table` wraps a mapping and its path (``parameters[1]``); its getters check the value's
TOML type and raise :class:`~fmucal_client.errors.JobFileError` for ``parameters[1].lower``.
The types follow what the CLI's serde reader accepts: a float field takes a TOML float or
integer, an integer field only a non-negative integer in range, a string field only a string.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from .errors import JobFileError


def describe(value: Any) -> str:
    """A value and its TOML type, for messages: ``'abc' (a string)``."""
    kinds = {bool: "a boolean", str: "a string", int: "an integer", float: "a float", list: "an array"}
    kind = next((k for t, k in kinds.items() if type(value) is t), None)
    if kind is None:
        kind = "a table" if isinstance(value, Mapping) else type(value).__name__
    return f"{value!r} ({kind})"


def join(path: str, name: str) -> str:
    """``path.name``, or ``name`` at the top level."""
    return f"{path}.{name}" if path else name


class Table:
    """A TOML table at ``path``; unknown keys are refused when it is made, and a key whose value
    is ``None`` counts as absent."""

    def __init__(self, value: Any, path: str, allowed: tuple[str, ...]) -> None:
        if not isinstance(value, Mapping):
            raise JobFileError(path or "job", f"expected a table, got {describe(value)}")
        for key in value:
            if not isinstance(key, str) or key not in allowed:
                raise JobFileError(join(path, str(key)), f"unknown field; expected one of {', '.join(allowed)}")
        # A dict job may write None for an absent field (TOML has no null).
        self.value: Mapping[str, Any] = {k: v for k, v in value.items() if v is not None}
        self.path = path

    def field(self, name: str) -> str:
        """The path of field ``name``."""
        return join(self.path, name)

    def has(self, name: str) -> bool:
        """Whether field ``name`` is given."""
        return name in self.value

    def raw(self, name: str) -> Any:
        """Field ``name`` as written (``None`` when absent)."""
        return self.value.get(name)

    def require(self, name: str) -> Any:
        """Field ``name``, which must be given."""
        if name not in self.value:
            raise JobFileError(self.field(name), "missing")
        return self.value[name]

    def text(self, name: str) -> str | None:
        """A string field, ``None`` when absent."""
        value = self.value.get(name)
        if value is None:
            return None
        if not isinstance(value, str):
            raise JobFileError(self.field(name), f"expected a string, got {describe(value)}")
        return value

    def required_text(self, name: str) -> str:
        """A string field that must be given."""
        value = self.require(name)
        if not isinstance(value, str):
            raise JobFileError(self.field(name), f"expected a string, got {describe(value)}")
        return value

    def required_number(self, name: str) -> float:
        """A float field that must be given."""
        return to_number(self.require(name), self.field(name))

    def number(self, name: str, required: bool = False) -> float | None:
        """A float field (a TOML float or integer)."""
        if required:
            self.require(name)
        return to_number(self.value.get(name), self.field(name)) if name in self.value else None

    def flag(self, name: str, default: bool) -> bool:
        """A boolean field."""
        value = self.value.get(name, default)
        if not isinstance(value, bool):
            raise JobFileError(self.field(name), f"expected true or false, got {describe(value)}")
        return value

    def count(self, name: str, bits: int = 64) -> int | None:
        """A non-negative integer field of at most ``bits`` bits."""
        if name not in self.value:
            return None
        value = self.value[name]
        if type(value) is not int:
            raise JobFileError(self.field(name), f"expected a non-negative integer, got {describe(value)}")
        if not 0 <= value < 2**bits:
            raise JobFileError(self.field(name), f"{value} is not a non-negative {bits}-bit integer")
        return value

    def table(self, name: str, allowed: tuple[str, ...]) -> Table | None:
        """A sub-table, ``None`` when absent."""
        return Table(self.value[name], self.field(name), allowed) if name in self.value else None

    def tables(self, name: str, allowed: tuple[str, ...]) -> list[Table] | None:
        """An array of tables (``[[name]]``), ``None`` when absent."""
        if name not in self.value:
            return None
        value = self.value[name]
        if not isinstance(value, list):
            raise JobFileError(self.field(name), f"expected an array of tables, got {describe(value)}")
        return [Table(item, f"{self.field(name)}[{k}]", allowed) for k, item in enumerate(value)]

    def mapping(self, name: str) -> Mapping[str, Any]:
        """An inline table of arbitrary keys (``set``, ``starts``); empty when absent."""
        value = self.value.get(name, {})
        if not isinstance(value, Mapping):
            raise JobFileError(self.field(name), f"expected a table, got {describe(value)}")
        return value


def to_number(value: Any, field: str) -> float:
    """A TOML float or integer as a float."""
    if type(value) not in (int, float):
        raise JobFileError(field, f"expected a number, got {describe(value)}")
    return float(value)
