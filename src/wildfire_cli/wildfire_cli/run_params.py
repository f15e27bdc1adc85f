"""``wildfire run --params-file``: a parameters file means what it says.

A value in the file wins over a default the user did not type: the file's ``shape: t`` flies
the T fire, and the summary says ``t``. A value the user typed that the file contradicts is
one line and exit status 2. Values that stand for one of the run's options (``seed``,
``shape``, ``policy``, ...) become that option's value before the run is built, so the
scenario, every node and the summary agree; the wind and the aircraft's start poses (drawn
from the seed unless given) take the file's values after. The rest of what the launcher
passes is the run's own wiring (``aircraft``, ``extra_reporters``, ...): the file may repeat
it but not change it.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, NoReturn, cast

import numpy as np
import yaml

from wildfire_cli.common import USER_ERRORS, ArgumentParser, UserError

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence
    from pathlib import Path

    AddParser = Callable[["argparse._SubParsersAction[argparse.ArgumentParser]"], Any]
    """Adds ``wildfire run``'s parser to a command's sub-parsers."""


@dataclass(frozen=True)
class Option:
    """A node parameter that stands for one of ``wildfire run``'s options."""

    dest: str
    """The option's attribute on the parsed arguments."""
    flag: str
    """How the option is typed, for messages."""
    words: Callable[[Any], list[str]]
    """The command-line words that give the option a parameter's value."""


def _mode_words(value: Any) -> list[str]:
    words = {"lockstep": ["--fast"], "realtime": ["--realtime"]}
    if value not in words:
        raise UserError(f"{value!r}: expected lockstep or realtime")
    return words[value]


def _switch_words(flag: str) -> Callable[[Any], list[str]]:
    def words(value: Any) -> list[str]:
        if not isinstance(value, bool):
            raise UserError(f"{value!r}: expected true or false")
        return [flag] if value else []

    return words


def _value_words(flag: str) -> Callable[[Any], list[str]]:
    return lambda value: [flag, str(value)]


OPTIONS = {
    "seed": Option("seed", "--seed", _value_words("--seed")),
    "shape": Option("shape", "--shape", _value_words("--shape")),
    "mode": Option("realtime", "--fast/--realtime", _mode_words),
    "duration_s": Option("duration", "--duration", _value_words("--duration")),
    "n_aircraft": Option("aircraft", "--aircraft", _value_words("--aircraft")),
    "policy": Option("policy", "--policy", _value_words("--policy")),
    "comm": Option("comm", "--comm", _value_words("--comm")),
    "sensor": Option("sensor", "--sensor", _value_words("--sensor")),
    "pixel_error": Option("pixel_error", "--pixel-error", _value_words("--pixel-error")),
    "wind_filter": Option("wind_filter", "--wind-filter", _switch_words("--wind-filter")),
}
"""Node parameters that stand for an option, by parameter name."""
START = {"start_x": 0, "start_y": 1, "start_heading": 2}
"""An agent's start pose parameters, by column of ``RunSpec.start``."""


_UNTYPED = object()
"""The default of an option in :func:`typed_options`' parse: left as it is, it was not typed."""


class _RaisingParser(ArgumentParser):
    """``wildfire run``'s parser raising what it would print, to reuse its checks."""

    def error(self, message: str) -> NoReturn:
        raise UserError(message)


def _run_parser(add_parser: AddParser, suppress: Sequence[str] = ()) -> argparse.ArgumentParser:
    """A parser of ``wildfire run`` alone; the options ``suppress`` names default to a marker."""
    top = _RaisingParser(prog="wildfire")
    # The sub-parsers are of the top's class: they raise too.
    subparsers = cast(
        "argparse._SubParsersAction[argparse.ArgumentParser]", top.add_subparsers(dest="command")
    )
    add_parser(subparsers)
    # Untyped, these options keep the marker (no text: argparse converts a text default).
    subparsers.choices["run"].set_defaults(**dict.fromkeys(suppress, _UNTYPED))
    return top


def check_params_file(path: Path) -> Path:
    """``--params-file``: readable YAML of ``<node>: {ros__parameters: {...}}`` entries."""
    try:
        content = yaml.safe_load(path.read_text())
    except OSError as error:
        raise UserError(f"--params-file {path}: cannot read it ({error.strerror})") from None
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        raise UserError(f"--params-file {path}: malformed YAML{where}") from None
    if not isinstance(content, dict) or not all(
        isinstance(v, dict) and isinstance(v.get("ros__parameters"), dict) for v in content.values()
    ):
        raise UserError(
            f"--params-file {path}: expected '<node>: {{ros__parameters: {{name: value}}}}' entries"
        )
    return path.resolve()


def typed_options(words: Sequence[str] | None, add_parser: AddParser) -> set[str]:
    """The options (by attribute) that the user typed on ``wildfire run``'s command line."""
    if words is None:
        return set()
    dests = [option.dest for option in OPTIONS.values()] + ["wind"]
    parsed = _run_parser(add_parser, dests).parse_args(list(words))
    return {d for d in dests if getattr(parsed, d) is not _UNTYPED}


def option_value(path: Path, node: str, name: str, value: Any, add_parser: AddParser) -> Any:
    """The file's ``value`` of parameter ``name`` as its option's value, checked as typed."""
    option = OPTIONS[name]
    where = f"--params-file {path}: {node} {name}"
    try:
        parsed = _run_parser(add_parser).parse_args(["run", *option.words(value)])
        if name == "shape":
            from wildfire_sim.shapes import Shape

            Shape.parse(parsed.shape)  # the option takes any text and checks it later
    except USER_ERRORS as error:
        raise UserError(f"{where}: {error}") from None
    return getattr(parsed, option.dest)


def adopt_options(
    args: argparse.Namespace, path: Path, typed: set[str], add_parser: AddParser
) -> dict[str, Any]:
    """Give ``args`` the file's values of the options it stands for; returns those it took."""
    from wildfire_bringup.params_file import file_values, node_name, run_nodes

    adopted: dict[str, Any] = {}
    # Twice at most: the file may change the team size, and with it the agents it names.
    for _ in range(2):
        # The live view (--foxglove) is a node the file may name too.
        nodes = run_nodes(args.aircraft, getattr(args, "foxglove", None) is not None)
        changed = False
        seen: dict[str, tuple[str, Any]] = {}
        for node, values in file_values(path, nodes).items():
            for name, value in values.items():
                if name not in OPTIONS:
                    continue
                if name in seen and seen[name][1] != value:
                    raise UserError(
                        f"--params-file {path}: {name} is {seen[name][1]!r} for {seen[name][0]} "
                        f"and {value!r} for {node_name(node)} (expected one value for the run)"
                    )
                seen.setdefault(name, (node_name(node), value))
        for name, (node, value) in seen.items():
            option = OPTIONS[name]
            wanted = option_value(path, node, name, value, add_parser)
            current = getattr(args, option.dest)
            if wanted == current:
                continue
            if option.dest in typed:
                raise UserError(
                    f"--params-file {path}: {node} {name} is {value!r}, but {option.flag} "
                    f"{current} was typed (expected one of them)"
                )
            setattr(args, option.dest, wanted)
            adopted[name] = value
            changed = True
        if not changed:
            break
    return adopted


def adopt_poses(
    spec: Any, values: list[Any], typed: set[str], path: Path
) -> tuple[Any, dict[str, Any]]:
    """The spec with the file's wind and start poses (drawn from the seed unless given)."""
    wind = list(spec.wind)
    start = np.array(spec.start, dtype=np.float64)
    adopted: dict[str, Any] = {}
    for entry in values:
        if not entry.passed or entry.agrees:
            continue
        if entry.node == "/fire_simulator" and entry.name in ("wind_x", "wind_y"):
            if "wind" in typed:
                raise UserError(
                    f"--params-file {path}: {entry.node} {entry.name} is {entry.file_value!r}, "
                    f"but --wind {spec.wind[0]:g},{spec.wind[1]:g} was typed "
                    "(expected one of them)"
                )
            wind["xy".index(entry.name[-1])] = float(entry.file_value)
        elif entry.name in START and entry.node.endswith("/agent"):
            k = int(entry.node.split("/")[1].removeprefix("uav"))
            start[k, START[entry.name]] = float(entry.file_value)
        else:
            continue
        adopted[f"{entry.node} {entry.name}"] = entry.file_value
    return replace(spec, wind=(wind[0], wind[1]), start=start), adopted


def with_params_file(
    args: argparse.Namespace, build: Callable[[argparse.Namespace], Any], add_parser: AddParser
) -> tuple[Any, dict[str, Any]]:
    """The run's spec built by ``build`` from ``args`` under ``args.params_file``, and the
    values it took from the file (by parameter; wind and poses by node and parameter).

    ``add_parser`` adds ``wildfire run``'s parser: the file's values are checked as if typed.
    It is passed in, so that this module needs nothing from ``wildfire_cli.run``."""
    from wildfire_bringup.launcher import node_commands
    from wildfire_bringup.params_file import compare

    if args.params_file is None:
        return build(args), {}
    path = check_params_file(args.params_file)
    typed = typed_options(getattr(args, "argv", None), add_parser)
    adopted = adopt_options(args, path, typed, add_parser)
    spec = build(args)
    spec, poses = adopt_poses(spec, compare(path, node_commands(spec)), typed, path)
    for entry in compare(path, node_commands(spec)):
        if entry.agrees or entry.name in OPTIONS:
            # Settled as options above (the launcher passes them resolved: a policy's path).
            continue
        raise UserError(
            f"--params-file {path}: {entry.node} {entry.name} is {entry.file_value!r}, but "
            f"the run sets it to {entry.run_value!r} itself (expected it left out of the file)"
        )
    return spec, adopted | poses


__all__ = [
    "OPTIONS",
    "adopt_options",
    "adopt_poses",
    "check_params_file",
    "typed_options",
    "with_params_file",
]
