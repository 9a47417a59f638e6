"""Dataclasses to JSON and back, by their type hints: a file format that holds data only.

What a run writes and later reads back (the grounding store) is untrusted once it is on disk:
another process, another user or a download may have put it there. Unlike a pickle, a document
here names no class: :func:`decode` builds the type it is *asked* for, field by field, from
the hints of that dataclass (nested dataclasses, ``list``/``tuple``/``set``/``dict``, unions, enums,
``str``/``int``/``float``/``bool``/``None``), and refuses anything else with
:class:`DecodeError` naming the field.
"""

from __future__ import annotations

import dataclasses
import enum
import functools
import types
import typing
from typing import Any, Union

_PLAIN = (str, int, float, bool, type(None))


class DecodeError(ValueError):
    """The document does not hold a value of the requested type; the message names where."""


def encode(value: Any) -> Any:
    """A dataclass (or a container of them) as JSON-ready data: dicts, lists, str, numbers, bools, None."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: encode(getattr(value, f.name)) for f in dataclasses.fields(value) if f.init}
    if isinstance(value, enum.Enum):
        return value.value
    if isinstance(value, list | tuple):
        return [encode(v) for v in value]
    if isinstance(value, set | frozenset):
        return sorted((encode(v) for v in value), key=repr)
    if isinstance(value, dict):
        return {str(k): encode(v) for k, v in value.items()}
    if isinstance(value, _PLAIN):
        return value
    raise TypeError(f"cannot encode {type(value).__name__} as JSON data")


@functools.cache
def _hints(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def decode(kind: Any, data: Any, where: str = "") -> Any:
    """``data`` (from :func:`encode`, through JSON) as a value of type ``kind``."""
    origin = typing.get_origin(kind)
    if kind is Any or kind is object:
        return _plain_tree(data, where)
    if origin in (Union, types.UnionType):
        options = typing.get_args(kind)
        if data is None and type(None) in options:
            return None
        errors = []
        for option in options:
            if option is type(None):
                continue
            try:
                return decode(option, data, where)
            except DecodeError as exc:
                errors.append(str(exc))
        raise DecodeError(errors[0] if len(errors) == 1 else f"{where or 'value'}: matches no type of {kind}")
    if dataclasses.is_dataclass(kind):
        if not isinstance(data, dict):
            raise DecodeError(f"{where or 'value'}: expected an object for {kind.__name__}")
        names = {f.name for f in dataclasses.fields(kind) if f.init}
        unknown = set(data) - names
        if unknown:
            raise DecodeError(f"{where or 'value'}: unknown field(s) {sorted(unknown)} for {kind.__name__}")
        hints = _hints(kind)
        return kind(**{name: decode(hints[name], value, f"{where}.{name}".lstrip(".")) for name, value in data.items()})
    if isinstance(kind, type) and issubclass(kind, enum.Enum):
        try:
            return kind(data)
        except ValueError:
            raise DecodeError(f"{where or 'value'}: {data!r} is not a {kind.__name__}") from None
    if origin in (set, frozenset):
        if not isinstance(data, list):
            raise DecodeError(f"{where or 'value'}: expected a list")
        (item,) = typing.get_args(kind) or (Any,)
        return origin(decode(item, v, f"{where}[{i}]") for i, v in enumerate(data))
    if origin in (list, tuple):
        if not isinstance(data, list):
            raise DecodeError(f"{where or 'value'}: expected a list")
        args = typing.get_args(kind)
        if origin is list or (len(args) == 2 and args[1] is Ellipsis):
            item = args[0] if args else Any
            items = [decode(item, v, f"{where}[{i}]") for i, v in enumerate(data)]
        else:
            if len(args) != len(data):
                raise DecodeError(f"{where or 'value'}: expected {len(args)} items, got {len(data)}")
            items = [decode(a, v, f"{where}[{i}]") for i, (a, v) in enumerate(zip(args, data, strict=True))]
        return items if origin is list else tuple(items)
    if origin is dict:
        if not isinstance(data, dict):
            raise DecodeError(f"{where or 'value'}: expected an object")
        _, value_kind = typing.get_args(kind) or (str, Any)
        return {k: decode(value_kind, v, f"{where}[{k!r}]") for k, v in data.items()}
    if kind is float and isinstance(data, int | float) and not isinstance(data, bool):
        return float(data)
    if kind in _PLAIN and isinstance(data, kind) and not (kind is int and isinstance(data, bool)):
        return data
    raise DecodeError(f"{where or 'value'}: expected {getattr(kind, '__name__', kind)}, got {type(data).__name__}")


def _plain_tree(data: Any, where: str) -> Any:
    """An untyped field (``object``): JSON values only; lists come back as tuples (hashable, as literals were)."""
    if isinstance(data, list):
        return tuple(_plain_tree(v, where) for v in data)
    if isinstance(data, dict):
        return {k: _plain_tree(v, where) for k, v in data.items()}
    if isinstance(data, _PLAIN):
        return data
    raise DecodeError(f"{where or 'value'}: not JSON data")
