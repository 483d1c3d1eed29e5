"""Stage parameters from defaults in the code, a TOML file (``--config``) and ``--set SECTION.FIELD=VALUE``.

A stage's parameters are frozen dataclasses, one per section: a TOML table ``[SECTION]`` or the prefix of a
``--set`` key. Later sources win: defaults, then the file, then each ``--set`` in order. Every value is checked
against its field's annotation (a float field takes any TOML number, a ``tuple[float, ...]`` field an array of
numbers, an int field an integer, ``X | None`` an X) before the dataclass validates it. Errors name the source
(file or command line), the section and the field, as a ConfigError (a ValueError: ``surrogacy`` prints it on one
line and exits with status 2).
"""

from __future__ import annotations

import argparse
import dataclasses
import tomllib
import types
import typing
from pathlib import Path

COMMAND_LINE = "command line"


class ConfigError(ValueError):
    """A configuration file or override that cannot be read, or names an unknown or ill-typed parameter."""


def parse_value(text: str):
    """A ``--set`` value as TOML (``0.005``, ``[0.0, 1.0]``, ``true``, ``"text"``); unquoted text otherwise."""
    try:
        return tomllib.loads(f"value = {text}")["value"]
    except tomllib.TOMLDecodeError:
        return text


def assignment(text: str) -> tuple[str, str, object]:
    """argparse type of ``--set SECTION.FIELD=VALUE``: (section, field, parsed value)."""
    key, separator, value = text.partition("=")
    section, dot, field = key.strip().partition(".")
    if not separator or not dot or not section or not field:
        raise argparse.ArgumentTypeError(f"expected SECTION.FIELD=VALUE, got {text!r}")
    return section, field, parse_value(value.strip())


def read_toml(path: Path) -> dict:
    """The tables of a TOML configuration file; ConfigError naming the file when it cannot be read."""
    try:
        return tomllib.loads(Path(path).read_text())
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as error:
        raise ConfigError(f"{path}: cannot read configuration ({error})") from None


def typed(value, annotation):
    """``value`` as the type ``annotation`` names (int -> float, list -> tuple); TypeError if it is not one."""
    origin, arguments = typing.get_origin(annotation), typing.get_args(annotation)
    if origin in (types.UnionType, typing.Union):
        for option in (a for a in arguments if a is not type(None)):
            try:
                return typed(value, option)
            except TypeError:
                pass
    elif origin is tuple and isinstance(value, (list, tuple)):
        return tuple(typed(item, arguments[0]) for item in value)
    elif annotation is float and isinstance(value, (int, float)) and not isinstance(value, bool):
        return float(value)
    elif isinstance(annotation, type) and isinstance(value, annotation) and not (
            isinstance(value, bool) and annotation is not bool):
        return value
    raise TypeError(f"expected {annotation.__name__ if isinstance(annotation, type) else annotation}")


def _section(default, values: dict, section: str, source: str):
    """``default`` (a dataclass instance) with ``values`` (field -> value) replaced, checked and validated."""
    annotations = typing.get_type_hints(type(default))
    fields = {f.name for f in dataclasses.fields(default)} - {"name"}
    unknown = set(values) - fields
    if unknown:
        raise ConfigError(f"{source}: unknown field(s) {sorted(unknown)} in [{section}]; "
                          f"expected some of {sorted(fields)}")
    checked = {}
    for field, value in values.items():
        try:
            checked[field] = typed(value, annotations[field])
        except TypeError as error:
            raise ConfigError(f"{source}: [{section}] field '{field}' = {value!r}: {error}") from None
    try:
        return dataclasses.replace(default, **checked)
    except ValueError as error:
        raise ConfigError(f"{source}: [{section}] {error}") from None


def resolve(defaults: dict, config: dict, overrides=(), source: str = COMMAND_LINE) -> dict:
    """Each section's parameters: ``defaults`` (section -> dataclass instance) with the TOML tables ``config``
    (section -> field -> value) and then ``overrides`` ((section, field, value), in order) applied.

    A field ``name`` is not configurable. Raises ConfigError naming ``source``, the section and the field of
    anything unknown, ill-typed or out of range.
    """
    table = {section: dict(values) if isinstance(values, dict) else values for section, values in config.items()}
    for section, field, value in overrides:
        table.setdefault(section, {})[field] = value
    unknown = set(table) - set(defaults)
    if unknown:
        raise ConfigError(f"{source}: unknown section(s) {sorted(unknown)}; expected some of {sorted(defaults)}")
    not_tables = sorted(section for section, values in table.items() if not isinstance(values, dict))
    if not_tables:
        raise ConfigError(f"{source}: {not_tables} must be tables ([section] with field = value lines)")
    return {section: _section(default, table.get(section, {}), section, source)
            for section, default in defaults.items()}


def add_config_arguments(command: argparse.ArgumentParser, sections: str, example: str) -> None:
    """Add ``--config FILE`` and repeatable ``--set SECTION.FIELD=VALUE`` to a stage's subcommand.

    sections: the TOML tables the stage reads, for the help; example: one override, for the help.
    """
    command.add_argument("--config", type=Path, help=f"TOML file with {sections} tables")
    command.add_argument("--set", type=assignment, action="append", default=[], metavar="SECTION.FIELD=VALUE",
                         help=f"override one parameter (after --config), e.g. {example}")


def configuration(arguments: argparse.Namespace, defaults: dict, options=()) -> dict:
    """Each section's parameters from ``defaults``, the ``--config`` file, ``--set`` and then ``options``
    ((section, field, value) of a stage's own command-line options, given ones only)."""
    if arguments.config is None:
        return resolve(defaults, {}, [*arguments.set, *options])
    return resolve(defaults, read_toml(arguments.config), [*arguments.set, *options], str(arguments.config))
