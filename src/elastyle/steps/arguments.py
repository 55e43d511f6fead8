"""The arguments of `pipeline.transfer` checked before any work: what to pass where a clip, a body part's
style or a second style's share is given otherwise (a `TypeError` or a `ConfigError` that says so)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from elastyle.core.motion import Motion
from elastyle.core.parts import parse_parts
from elastyle.errors import ConfigError
from elastyle.steps.schedule import Schedule


def check_clip_type(value: object, role: str) -> None:
    """A TypeError that says what to do when a path or other object is given where a clip belongs."""
    if isinstance(value, tuple) and value and isinstance(value[0], Motion):
        raise TypeError(
            f"the {role} must be a Motion, got a tuple of a Motion and more (read_bvh's (motion, layout)?): "
            "pass its motion"
        )
    if not isinstance(value, Motion):
        raise TypeError(
            f"the {role} must be a Motion, got {type(value).__name__} {value!r:.80}: read a file first with "
            "elastyle.read_bvh(path), which returns (motion, layout)"
        )


def check_part_styles(part_styles: object, kept: tuple[str, ...]) -> None:
    """A TypeError where `part_styles` is no mapping of part names to styles, a ConfigError where a part is
    both kept and styled by another library (the command line's rule)."""
    if part_styles is None:
        return
    if not isinstance(part_styles, Mapping):
        raise TypeError(
            f"part_styles must map body part names to styles, e.g. {{'arms': clip}}, got "
            f"{type(part_styles).__name__} {part_styles!r:.60}"
        )
    for names, style in part_styles.items():
        if not isinstance(names, str):
            raise TypeError(
                f"part_styles: a key must name body parts ('arms', 'legs,spine'), got {names!r:.40}"
            )
        if style is None:
            raise TypeError(
                f"part_styles[{names!r}]: give a clip, clips or a prepared StyleLibrary, got None"
            )
    both = sorted({p for names in part_styles for p in parse_parts(names, "part_styles")} & set(kept))
    if both:
        raise ConfigError(
            f"part_styles: {', '.join(both)} both kept (keep_part) and given another style; give one",
            "part_styles",
        )


def second_schedule(second_style: object, second_weight: float | str | Schedule | None) -> Schedule:
    """The second style's share over content time (0 throughout without one): a `ConfigError` for a share
    without a second style, or a second style without its share."""
    if second_style is None:
        if second_weight is not None and np.any(as_schedule(second_weight).values):
            raise ConfigError("second_weight is the share of second_style, and no second_style is given")
        return Schedule.constant(0.0)
    if second_weight is None:
        raise ConfigError(
            "second_weight: second_style is given without its share; give it (0 to 1) or keyframes "
            "('SECONDS:SHARE,...') for a transition",
            "second_weight",
        )
    return as_schedule(second_weight)


def as_schedule(value: float | str | Schedule) -> Schedule:
    if isinstance(value, Schedule):
        return value
    return Schedule.parse(value if isinstance(value, str) else str(float(value)), "second_weight")


def arms_treated_apart(kept_parts: Sequence[str], part_styles: Mapping[str, object] | None) -> bool:
    """Whether --keep-part and --style-part treat the left and the right arm differently (naming one arm,
    or each with another style), so which arm is the left one matters."""

    def treatment(arm: str) -> str | None:
        if arm in kept_parts:
            return "kept"
        return next((names for names in part_styles or {} if arm in parse_parts(names, "part_styles")), None)

    return treatment("left-arm") != treatment("right-arm")
