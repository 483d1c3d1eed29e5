"""``surrogacy beams``: mesh the Brake-Reuss beams (the geometry stage)."""

from __future__ import annotations

import argparse
import dataclasses
import tomllib
from pathlib import Path

from tqdm import tqdm

from .beams import make_beam
from .parameters import BEAMS, GeometryError, MeshParameters


def _assignment(text: str) -> tuple[list[str], str]:
    key, separator, value = text.partition("=")
    if not separator or "." not in key:
        raise argparse.ArgumentTypeError(f"expected SECTION.FIELD=VALUE, got {text!r}")
    return key.split("."), value


def _parse_value(text: str):
    try:
        return tomllib.loads(f"value = {text}")["value"]
    except tomllib.TOMLDecodeError:
        return text


def resolve(config: dict, overrides: list[tuple[list[str], str]], source: str = "command line"):
    """Beams and mesh sizes from defaults, a TOML table and ``SECTION.FIELD=VALUE`` overrides.

    Sections: ``mesh`` (MeshParameters fields) and one per beam name (BeamParameters fields).
    Raises GeometryError naming the source, section and field of anything unknown or out of range.
    """
    table = {section: dict(values) for section, values in config.items()}
    for (section, *path), value in overrides:
        table.setdefault(section, {})[".".join(path)] = _parse_value(value)
    sections = {"mesh": MeshParameters(), **BEAMS}
    resolved = {}
    for section, default in sections.items():
        values = table.pop(section, {})
        fields = {f.name for f in dataclasses.fields(default)} - {"name"}
        unknown = set(values) - fields
        if unknown:
            raise GeometryError(f"{source}: unknown field(s) {sorted(unknown)} in [{section}]; "
                                f"expected some of {sorted(fields)}")
        values = {k: tuple(v) if isinstance(v, list) else v for k, v in values.items()}
        try:
            resolved[section] = dataclasses.replace(default, **values)
        except GeometryError as error:
            raise GeometryError(f"{source}: [{section}] {error}") from None
    if table:
        raise GeometryError(f"{source}: unknown section(s) {sorted(table)}; expected mesh or one of {sorted(BEAMS)}")
    return resolved


def run(arguments: argparse.Namespace) -> None:
    config, source = {}, "command line"
    if arguments.config:
        source = str(arguments.config)
        try:
            config = tomllib.loads(Path(arguments.config).read_text())
        except (OSError, tomllib.TOMLDecodeError) as error:
            raise GeometryError(f"{arguments.config}: cannot read configuration ({error})") from None
    resolved = resolve(config, arguments.set, source)
    for name in tqdm(arguments.beam, desc="meshing beams", unit="beam"):
        sidecar = make_beam(resolved[name], resolved["mesh"], arguments.out, render=not arguments.no_render)
        tqdm.write(f"{name}: {sidecar}")


def register(subparsers) -> None:
    """Add the ``beams`` subcommand."""
    command = subparsers.add_parser(
        "beams", help="mesh the BRB, LBRB and SBRB (gmsh): .msh, .vtu, .png and a .json sidecar per beam",
        description=__doc__)
    command.add_argument("--beam", nargs="+", choices=sorted(BEAMS), default=list(BEAMS), help="beams to mesh")
    command.add_argument("--out", type=Path, default=Path("build/beams"), help="output folder")
    command.add_argument("--config", type=Path, help="TOML file with [mesh] and per-beam [BRB]/[LBRB]/[SBRB] tables")
    command.add_argument("--set", type=_assignment, action="append", default=[], metavar="SECTION.FIELD=VALUE",
                         help="override one parameter, e.g. mesh.size=0.005 or SBRB.spring_height=0.007")
    command.add_argument("--no-render", action="store_true", help="skip the PNG renders")
    command.set_defaults(run=run)
