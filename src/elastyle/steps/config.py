"""How to transfer: `TransferConfig`, the one place where every transfer option is declared.

Each field carries its help text and its allowed values (choices, or a numeric range); the command line
builds its `transfer` flags from these fields (`elastyle.cli.options`) and the dataclass validates them
once, in `__post_init__`, whether the values come from Python or from the command line.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np

from elastyle.core.parts import parse_parts
from elastyle.errors import ConfigError
from elastyle.steps.schedule import Schedule
from elastyle.types import IntArray

METHODS = ("elastic", "rigid", "wct", "adain")
PLACEMENTS = ("sequential", "fixed")
TIMINGS = ("style", "content")
STRETCH_CENTRES = ("tempo", "content")
DECODINGS = ("residual", "plain")


def option(
    default: Any,
    help: str,
    choices: tuple[str, ...] | None = None,
    low: float | None = None,
    high: float | None = None,
    low_open: bool = False,
    high_open: bool = False,
    text: bool = False,
    listed: bool = False,
) -> Any:
    """A config field with its command-line help and allowed values ([low, high], ends open if asked);
    `text`: the flag's value is passed on as written (a number or keyframes); `listed`: a comma-separated
    list, which a repeated flag extends."""
    metadata = {"help": help, "choices": choices, "low": low, "high": high, "text": text, "listed": listed}
    metadata |= {"low_open": low_open, "high_open": high_open}
    return field(default=default, metadata=metadata)


@dataclass(frozen=True)
class TransferConfig:
    """How to transfer. Times are in seconds; frame counts follow the model's frame rate."""

    method: str = option("elastic", "the report's method or one of its ablations", METHODS)
    placement: str = option(
        "sequential",
        "sequential: the output takes the style's timing; fixed: the report read literally",
        PLACEMENTS,
    )
    patch_s: float = option(1.0, "patch length, seconds", low=0.0, high=60.0, low_open=True)
    stretch: float = option(
        0.25,
        "a content patch may be read from (1 - stretch) to (1 + stretch) times its length (each end rounded to "
        "whole frames, so a patch of a few frames reaches a little further)",
        low=0.0, high=1.0, high_open=True,
    )  # fmt: skip
    stretch_centre: str = option(
        "tempo",
        "sequential placement: the tried stretches centre on the clip's tempo, the median stretch of the "
        "patches whose legs step alike in a first search, searched again up to twice (a style up to about "
        "(1 + stretch)^3 times faster or (1 - stretch)^3 slower than the content is reached); content: on "
        "the content's own pace, the report's range",
        STRETCH_CENTRES,
    )
    stretch_step_s: float = option(
        4 / 60, "spacing of the tried patch lengths, seconds (the report's 4 frames at 60 fps; 0 = every frame)",
        low=0.0, high=10.0,
    )  # fmt: skip
    strength: float | str = option(
        1.0, "0 (the content) to 1 (full style), or keyframes in content seconds such as 0:0,2:1", text=True
    )
    mirror_style: bool = option(True, "add each style clip's mirror to its library")
    reverse_style: bool = option(
        False,
        "add each style clip played backwards to its library, so a content that walks backwards finds the "
        "style's steps (off by default: forward contents then sometimes take reversed windows)",
    )
    loop: bool = option(
        False,
        "the content is a cycle (its last frame runs into its first, as a game's walk or run cycle loops): "
        "transferred as three cycles end to end, the output is the middle one's, its seam cross-faded, so it "
        "loops too (a constant strength)",
    )
    whiten_floor: float = option(
        0.1,
        "whitening: each latent direction's variance is floored at this fraction of the mean variance, so "
        "directions that hardly vary are not amplified into the match (1e-4: about the report's whitening)",
        low=0.0, high=10.0, low_open=True,
    )  # fmt: skip
    action_weight: float = option(
        2.0,
        "matching: weight of what the body does (travel, hands, feet; steps.action) beside the whitened "
        "latents, so a window performing another action is not swapped in (0: latents alone, the report's "
        "matching)",
        low=0.0, high=100.0,
    )  # fmt: skip
    match_step_s: float = option(
        0.0,
        "matching compares a content patch and a style window on frames this far apart, seconds (0: every "
        "frame; 0.067, every other frame at 30 fps, halves the search's arithmetic for a long style library "
        "but picks other windows among near-equal ones: on the referee with the previous model, walk timing "
        "error 0.06 -> 0.16, turn naturalness 2.29 -> 2.51, cross style / content recognised 0.78 / 0.83 -> "
        "0.72 / 0.78)",
        low=0.0, high=1.0,
    )  # fmt: skip
    fallback_below: float = option(
        -1.0,
        "where the best style window's similarity (cosine, -1 to 1) is below this, the style's statistics "
        "alone colour the content's own latents (eased over 0.15 of similarity and a quarter patch); -1: never",
        low=-1.0, high=1.0,
    )  # fmt: skip
    keep_action_above: float = option(
        0.35,
        "per body part: where the legs' travel and steps differ from the matched style windows' by more than "
        "this (relative RMS of their action descriptors), the legs and spine keep the content's action and "
        "pace (the spine with the style's mean posture), eased in over 0.15 above it (a walk given a run's or "
        "a wave's style still walks); 2: never",
        low=0.0, high=2.0,
    )  # fmt: skip
    legs_turning_above: float = option(
        0.5,
        "per body part: where the legs' sustained turning (yaw rate low-passed over 0.5 s) differs from the "
        "matched style windows' by more than this (rad/s), the legs and spine keep the content's action (its "
        "turning steps, at the style's cadence), eased in over 0.15 above it (a turning walk given a straight "
        "walk's style still turns); 9: never",
        low=0.0, high=9.0,
    )  # fmt: skip
    legs_place_above: float = option(
        0.12,
        "per body part: where the content does not travel and its feet's and pelvis's heights (less their "
        "mean over the clip's highest tenth) differ over a patch from the matched style window's by more than "
        "this (leg lengths), the legs and spine keep the content's action (a kick or a crouch given a standing "
        "clip's style still kicks or crouches), eased in over 0.15 above it; 9: never",
        low=0.0, high=9.0,
    )  # fmt: skip
    kept_statistics: float = option(
        0.45,
        "where the legs keep the content's action because the matched style windows perform another (their "
        "travel and steps differ, not only their turning: a walk given a run's or a wave's style), the share of "
        "the style's statistics (the report's colouring of the content's latents) they take on top of it "
        "(none where they do not travel: a stepping style's statistics are a stride's bent knees); 0: the content's "
        "own legs",
        low=0.0, high=1.0,
    )  # fmt: skip
    arm_offset_above: float = option(
        0.4,
        "per arm: where the hand's mean place over a patch lies more than this (leg lengths) from the matched "
        "style window's, the arm keeps the content's action (a raised hand given a walk's style stays raised), "
        "eased in over 0.15 above it; 9: never (the arms still keep it where the content keeps its place and "
        "its legs their action while the windows travel)",
        low=0.0, high=9.0,
    )  # fmt: skip
    arm_rhythm_above: float = option(
        0.28,
        "per arm: where the share of the hand's path that comes back on itself within a second (a wave or a "
        "swing: near 1; a raise or a hold: near 0) differs from the matched window's by more than this, the "
        "arm keeps the content's action (a raise given a wave's style does not wave), eased in over 0.15 "
        "above it; 1: never",
        low=0.0, high=1.0,
    )  # fmt: skip
    spine_lean_above: float = option(
        0.15,
        "per body part: where the content does not travel and its head's lean away from its usual carriage (its "
        "place relative to the pelvis, less that over the clip's most upright tenth) or its gaze (where it faces, "
        "as a point 0.75 leg lengths ahead, where the content's turns at least as far as the window's) differs "
        "at some frame of a patch from the matched style window's by more than this (leg lengths), the spine "
        "keeps the content's action (a bow or a nod given a wave's style still bows or nods), eased in over 0.15 "
        "above it; where the content travels, its gaze alone counts, at twice this (a look aside while walking); "
        "9: never",
        low=0.0, high=9.0,
    )  # fmt: skip
    keep_part: str = option(
        "",
        "body parts performed as in the content (comma-separated or repeated: legs, spine, left-arm, "
        "right-arm, arms); kept legs keep the content's pace too",
        listed=True,
    )
    smooth_s: float = option(
        1 / 30, "Gaussian low-pass of the decoded motion, sigma in seconds (0: none; the default is one frame at 30 fps)",
        low=0.0, high=10.0,
    )  # fmt: skip
    timing: str = option(
        "style", "style: the style's pace; content: warped back onto the content's clock", TIMINGS
    )
    decode: str = option(
        "residual",
        "residual: the content composed with the style's change to the model's reading of it (strength 0 is "
        "the content); plain: the report's decoding of the styled latents",
        DECODINGS,
    )
    residual_smooth_s: float = option(
        0.1, "residual decoding: low-pass (sigma, seconds) of the model's error carried at full strength",
        low=0.0, high=10.0,
    )  # fmt: skip
    cleanup: bool = option(True, "plant the feet: contacts pinned by two-joint leg IK")
    root_follows_legs: float = option(
        0.5,
        "the share of the stance feet's drift the root takes before the clean-up, where the body travels: 0 "
        "keeps the content's path exactly (the legs stretch to cover it), 1 moves the root with the legs' "
        "stride; the root strays at most a tenth of the path's length and 1.5 leg lengths from the path (the "
        "share is lowered as a whole to stay within it, so past that a larger share changes nothing)",
        low=0.0, high=1.0,
    )  # fmt: skip

    def __post_init__(self) -> None:
        if isinstance(self.keep_part, (list, tuple)):  # parts as a list in Python, as comma-separated text
            object.__setattr__(self, "keep_part", ",".join(map(str, self.keep_part)))
        if isinstance(self.strength, Schedule):  # keyframes as the command line writes them
            object.__setattr__(self, "strength", self.strength.text())
        for spec in fields(self):
            value = getattr(self, spec.name)
            # numpy's numbers and booleans as Python's, so the explain record (which copies the fields) is JSON
            if isinstance(value, (np.bool_, np.number)):
                value = value.item()
                object.__setattr__(self, spec.name, value)
            if spec.type == "bool" and not isinstance(value, (bool, np.bool_)):
                raise ConfigError(f"{spec.name}: must be True or False, got {value!r}", spec.name)
            if spec.type == "str" and not isinstance(value, str):
                raise ConfigError(f"{spec.name}: must be text, got {value!r}", spec.name)
            _check(spec.name, value, spec.metadata)
        parse_parts(self.keep_part, "keep_part")
        if isinstance(self.strength, str):
            Schedule.parse(self.strength, "strength")
        elif isinstance(self.strength, numbers.Real) and not isinstance(self.strength, (bool, np.bool_)):
            Schedule.parse(str(float(self.strength)), "strength")
        else:
            raise ConfigError(
                f"strength: a number from 0 to 1 or a schedule 'SECONDS:VALUE,...', got {self.strength!r}",
                "strength",
            )

    @staticmethod
    def of(config: TransferConfig | None = None, **options: Any) -> TransferConfig:
        """`config` (or the defaults) with `options` replaced; a `ConfigError` names an unknown option."""
        if config is not None and not isinstance(config, TransferConfig):
            raise ConfigError(
                f"config must be a TransferConfig, got {type(config).__name__} {config!r:.60}: give options as "
                "keywords (transfer(content, style, strength=0.5)) or TransferConfig(strength=0.5)"
            )
        config = config or TransferConfig()
        known = {spec.name for spec in fields(TransferConfig)}
        unknown = sorted(set(options) - known)
        if unknown:
            raise ConfigError(f"unknown transfer option {unknown[0]!r}; options: {', '.join(sorted(known))}")
        return replace(config, **options) if options else config

    @property
    def kept_parts(self) -> tuple[str, ...]:
        """The parts `keep_part` names, groups expanded."""
        return parse_parts(self.keep_part, "keep_part")

    @property
    def strength_schedule(self) -> Schedule:
        text = self.strength if isinstance(self.strength, str) else str(float(self.strength))
        return Schedule.parse(text, "strength")

    def match_frame_step(self, fps: float) -> int:
        """`match_step_s` in frames at `fps` (at least 1)."""
        return max(1, int(round(self.match_step_s * fps)))

    def unread_options(self, patch_frames: int, fps: float) -> list[tuple[list[str], str]]:
        """The options set away from their defaults that change nothing here (as flags), in groups, each with
        why: the statistics methods (wct, adain) match no patches on the content's own clock, rigid tries no
        stretch, a stretch (or its step) that reaches no other whole length tries only the patch's own, the fixed
        placement keeps the content's clock, plain decoding has no residual, no clean-up has no root to
        move, and kept arms take no windows to compare."""
        default = TransferConfig()
        patchless = ("placement", "timing", "patch_s", "stretch", "stretch_step_s", "stretch_centre")
        unmatched = (
            "action_weight", "match_step_s", "fallback_below", "keep_action_above", "legs_turning_above",
            "legs_place_above",
            "kept_statistics", "arm_offset_above", "arm_rhythm_above", "spine_lean_above",
        )  # fmt: skip
        colours = "colours the content's own latents on its own clock, no patches"
        by_method: dict[str, list[tuple[tuple[str, ...], str]]] = {
            "wct": [(patchless + unmatched, f"--method wct {colours}")],
            "adain": [(patchless + unmatched + ("whiten_floor",), f"--method adain {colours}")],
            "rigid": [(("stretch", "stretch_step_s", "stretch_centre"), "--method rigid reads every patch at its own length")],
        }  # fmt: skip
        groups = list(by_method.get(self.method, []))
        if self.method == "elastic" and self.stretch > 0 and len(self.source_lengths(patch_frames, fps)) == 1:
            step = max(1, int(round(self.stretch_step_s * fps)))
            groups.append((("stretch", "stretch_step_s"), (
                f"a patch of {patch_frames} frames at {fps:g} fps stretched by {self.stretch:g} reaches no other "
                f"length {step} frame(s) apart, so only its own is tried and the output keeps the content's timing"
            )))  # fmt: skip
        if self.method in ("elastic", "rigid") and self.placement == "fixed":
            groups.append(
                (("stretch_centre", "timing"), "--placement fixed keeps the content's clock, searching no tempo")
            )  # fmt: skip
        if self.decode == "plain":
            groups.append((("residual_smooth_s",), "--decode plain has no residual to smooth"))
        if not self.cleanup:
            groups.append((("root_follows_legs",), "--no-cleanup: no clean-up, whose root follows the legs"))
        if "spine" in self.kept_parts:
            groups.append((("spine_lean_above",), "--keep-part keeps the spine as the content performs it"))
        if {"left-arm", "right-arm"} <= set(self.kept_parts):
            groups.append(
                (("arm_offset_above", "arm_rhythm_above"), "--keep-part keeps both arms as the content performs them")
            )  # fmt: skip
        found = []
        for names, why in groups:
            changed = [name for name in names if getattr(self, name) != getattr(default, name)]
            if changed:
                found.append((["--" + name.replace("_", "-") for name in changed], why))
        return found

    def source_lengths(self, patch_frames: int, fps: float, tempo: float = 1.0) -> IntArray:
        """Candidate source lengths L' (frames) for a patch of L frames: (1 - stretch) to (1 + stretch)
        times tempo * L, in steps of `stretch_step_s` from tempo * L (the content's own pace at tempo 1)."""
        if self.method != "elastic" or self.stretch == 0:
            return np.array([patch_frames])
        centre = max(2, int(round(tempo * patch_frames)))
        low = max(2, int(round((1 - self.stretch) * tempo * patch_frames)))
        high = int(round((1 + self.stretch) * tempo * patch_frames))
        step = max(1, int(round(self.stretch_step_s * fps)))
        lengths = set(range(centre, low - 1, -step)) | set(range(centre, high + 1, step))
        return np.array(sorted(lengths))


def range_text(metadata: Any) -> str:
    """A field's allowed range as an interval, '[0, 1]' or '(0, 60]'."""
    left = "(" if metadata["low_open"] else "["
    right = ")" if metadata["high_open"] else "]"
    return f"{left}{metadata['low']:g}, {metadata['high']:g}{right}"


def _field_list() -> str:
    """Each field of `TransferConfig` with its default, allowed values and meaning, for its docstring."""
    lines = []
    for spec in fields(TransferConfig):
        meta = spec.metadata
        allowed = f" ({', '.join(meta['choices'])})" if meta.get("choices") else ""
        if meta.get("low") is not None:
            allowed = f" {range_text(meta)}"
        lines.append(f"    {spec.name} = {spec.default!r}{allowed}: {meta['help']}")
    return "\n".join(lines)


TransferConfig.__doc__ = (
    f"{TransferConfig.__doc__}\n\nFields (default, allowed values: meaning):\n{_field_list()}\n"
)


def _check(name: str, value: Any, metadata: Any) -> None:
    """One field against its declared choices and range; `ConfigError` naming the field."""
    choices = metadata.get("choices")
    if choices is not None and value not in choices:
        raise ConfigError(f"{name}: unknown value {value!r}; choose one of {', '.join(choices)}", name)
    low, high = metadata.get("low"), metadata.get("high")
    if low is None and high is None:
        return
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real) or not math.isfinite(value):
        raise ConfigError(f"{name}: must be a finite number, got {value!r}", name)
    below = value <= low if metadata["low_open"] else value < low
    above = value >= high if metadata["high_open"] else value > high
    if below or above:
        raise ConfigError(f"{name}: must lie in {range_text(metadata)}, got {value:g}", name)
