"""Command-line flags built from a config dataclass's fields: one declaration of every option.

A field `patch_s` becomes `--patch-s`; a boolean that defaults on becomes `--no-x`, one that defaults off
`--x`; choices and help come from the field's metadata (`steps.config.option`). Values are checked by the
dataclass itself when it is built, so a wrong value is reported the same way from Python and the shell.
"""

from __future__ import annotations

import argparse
from dataclasses import MISSING, Field, fields
from typing import Any

from elastyle.errors import ConfigError
from elastyle.steps.config import range_text


def _flag(spec: Field[Any]) -> str:
    """A field's flag: `--patch-s` for `patch_s`; a boolean that defaults on `--no-x`."""
    flag = spec.name.replace("_", "-")
    return f"--no-{flag}" if spec.default is True else f"--{flag}"


def add_config_flags(parser: argparse.ArgumentParser, config_type: type) -> None:
    """One flag per field of `config_type`, with its default shown in the help."""
    for spec in fields(config_type):
        flag = spec.name.replace("_", "-")
        default = spec.default if spec.default is not MISSING else None
        help_text = spec.metadata.get("help", "")
        if isinstance(default, bool):
            name = _flag(spec)
            action = "store_false" if default else "store_true"
            # the help says what the field does; a --no-x flag turns that off
            shown = f"turn off what is on by default: {help_text}" if default else help_text
            parser.add_argument(name, dest=spec.name, action=action, default=default, help=shown)
            continue
        choices = spec.metadata.get("choices")
        kind = str if spec.metadata.get("text") or not isinstance(default, (int, float)) else type(default)
        listed = bool(spec.metadata.get("listed"))  # repeats gathered, joined by `config_from_args`
        allowed = f"; allowed {range_text(spec.metadata)}" if spec.metadata.get("low") is not None else ""
        parser.add_argument(
            f"--{flag}", dest=spec.name, action="append" if listed else "store", type=kind, choices=choices,
            default=None if listed else default, help=f"{help_text} (default: {_shown(default)}{allowed})",
        )  # fmt: skip


def config_from_args(config_type: type, args: argparse.Namespace) -> Any:
    """The config built from the flags `add_config_flags` declared (validated by the config); a listed
    field's repeats joined by commas, its default where it was not given."""
    values = {}
    for spec in fields(config_type):
        value = getattr(args, spec.name)
        if spec.metadata.get("listed"):
            value = spec.default if value is None else ",".join(value)
        values[spec.name] = value
    try:
        return config_type(**values)
    except ConfigError as error:  # its message names the field as Python does: here, its flag
        flags = {spec.name: _flag(spec) for spec in fields(config_type)}
        if error.option not in flags or not str(error).startswith(error.option):
            raise
        raise ConfigError(flags[error.option] + str(error)[len(error.option) :], error.option) from None


def _shown(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value) if value != "" else "none"


def add_units_flag(
    parser: argparse.ArgumentParser,
    effect: str = "clips are transferred at the model's size and written at their own, and it scales reported "
    "figures and .glb output",
) -> None:
    """`--units`: the clips' length unit, where the guess from the body's height would be wrong; `effect`
    says what the command does with it."""
    from elastyle.core.body import UNITS

    parser.add_argument(
        "--units", choices=sorted(UNITS),
        help="the BVH clips' length unit (default: guessed from the body's height, read from its bone lengths: "
        "metres below 5 units tall, inches from 40 to 90, millimetres from 500, else centimetres; .glb clips "
        f"are metres); {effect}",
    )  # fmt: skip
