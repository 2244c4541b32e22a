"""Strict YAML -> frozen dataclass loading.

Dataclasses are the schema, YAML holds the values. Unknown keys, missing required keys
and wrong shapes are `ConfigError`s that name the file and the dotted key.
"""

from __future__ import annotations

import dataclasses
import types
import typing
from pathlib import Path
from typing import Any, TypeVar

import yaml

from hw.errors import ConfigError

T = TypeVar("T")


def load_yaml(path: Path) -> Any:
    """Parse a YAML file; a missing file or a syntax error is a `ConfigError`."""
    try:
        text = path.read_text()
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read ({exc.strerror})") from exc
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: invalid YAML: {exc}".replace("\n", " ")) from exc


def load_config(cls: type[T], path: Path) -> T:
    """Load `path` into the dataclass `cls`."""
    return from_dict(cls, load_yaml(path), source=str(path))


def from_dict(cls: type[T], data: Any, source: str, key: str = "") -> T:
    """Build dataclass `cls` from plain data, checking every key and type."""
    return typing.cast(T, _convert(cls, data, source, key))


def _where(source: str, key: str) -> str:
    return f"{source}: {key}" if key else source


def _convert(tp: Any, value: Any, source: str, key: str) -> Any:
    origin = typing.get_origin(tp)
    if dataclasses.is_dataclass(tp) and isinstance(tp, type):
        return _convert_dataclass(tp, value, source, key)
    if origin in (typing.Union, types.UnionType):
        args = typing.get_args(tp)
        if value is None and type(None) in args:
            return None
        errors = []
        for arg in args:
            if arg is type(None):
                continue
            try:
                return _convert(arg, value, source, key)
            except ConfigError as exc:
                errors.append(str(exc))
        raise ConfigError(errors[0] if len(errors) == 1 else f"{_where(source, key)}: value {value!r} matches none of {tp}")
    if origin is tuple:
        args = typing.get_args(tp)
        if not isinstance(value, list | tuple):
            raise ConfigError(f"{_where(source, key)}: expected a list, got {type(value).__name__}")
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_convert(args[0], v, source, f"{key}[{i}]") for i, v in enumerate(value))
        if len(value) != len(args):
            raise ConfigError(f"{_where(source, key)}: expected {len(args)} values, got {len(value)}")
        return tuple(_convert(a, v, source, f"{key}[{i}]") for i, (a, v) in enumerate(zip(args, value, strict=True)))
    if origin is dict:
        kt, vt = typing.get_args(tp)
        if not isinstance(value, dict):
            raise ConfigError(f"{_where(source, key)}: expected a mapping, got {type(value).__name__}")
        return {_convert(kt, k, source, key): _convert(vt, v, source, f"{key}.{k}" if key else str(k)) for k, v in value.items()}
    if origin is typing.Literal:
        allowed = typing.get_args(tp)
        if value not in allowed:
            raise ConfigError(f"{_where(source, key)}: {value!r} is not one of {', '.join(map(repr, allowed))}")
        return value
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(f"{_where(source, key)}: expected a number, got {value!r}")
        return float(value)
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{_where(source, key)}: expected an integer, got {value!r}")
        return value
    if tp is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{_where(source, key)}: expected true or false, got {value!r}")
        return value
    if tp is str:
        if not isinstance(value, str):
            raise ConfigError(f"{_where(source, key)}: expected a string, got {value!r}")
        return value
    if tp is Any:
        return value
    raise TypeError(f"unsupported config type {tp!r} at {key}")


def _convert_dataclass(cls: type, value: Any, source: str, key: str) -> Any:
    if value is None:
        value = {}
    if not isinstance(value, dict):
        raise ConfigError(f"{_where(source, key)}: expected a mapping, got {type(value).__name__}")
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    unknown = sorted(set(value) - set(fields))
    if unknown:
        where = f"{key}.{unknown[0]}" if key else str(unknown[0])
        raise ConfigError(f"{source}: unknown key '{where}' (valid keys: {', '.join(sorted(fields))})")
    kwargs = {}
    for name, field in fields.items():
        sub = f"{key}.{name}" if key else name
        if name in value:
            kwargs[name] = _convert(hints[name], value[name], source, sub)
        elif field.default is dataclasses.MISSING and field.default_factory is dataclasses.MISSING:
            raise ConfigError(f"{source}: missing required key '{sub}'")
    try:
        return cls(**kwargs)
    except ValueError as exc:  # __post_init__ validation
        raise ConfigError(f"{_where(source, key)}: {exc}") from exc


def preset_names(folder: Path) -> list[str]:
    """The presets of a config folder: its YAML files by stem."""
    return sorted(p.stem for p in folder.glob("*.yaml"))


def resolve_preset(name_or_path: str, folder: Path, kind: str) -> Path:
    """A preset of `folder` by name, or a YAML file by path; an unknown name lists the valid ones."""
    path = Path(name_or_path)
    if path.suffix in (".yaml", ".yml") and path.is_file():
        return path
    path = folder / f"{name_or_path}.yaml"
    if not path.is_file():
        raise ConfigError(f"unknown {kind} '{name_or_path}' (available: {', '.join(preset_names(folder))}, or a path to a .yaml file)")
    return path


def check_position_limits(limits: tuple[float, float]) -> None:
    """A joint's [low, high] position limits, in that order (both joint-map kinds check them alike)."""
    lo, hi = limits
    if not lo < hi:
        raise ValueError(f"position_limits must be [low, high] with low < high, got {list(limits)}")
