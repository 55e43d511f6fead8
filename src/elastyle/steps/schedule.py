"""Values that change over time: a constant, or keyframes 'SECONDS:VALUE,...' interpolated linearly."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from elastyle.errors import ConfigError
from elastyle.types import FloatArray


class Schedule(NamedTuple):
    """Keyframes (times_s (K,), values (K,)); held constant before the first and after the last."""

    times_s: tuple[float, ...]
    values: tuple[float, ...]

    def text(self) -> str:
        """The schedule as `parse` reads it: 'SECONDS:VALUE,...' ('VALUE' for a constant)."""
        if len(self.values) == 1:
            return f"{self.values[0]:.17g}"
        return ",".join(f"{t:.17g}:{v:.17g}" for t, v in zip(self.times_s, self.values))

    @staticmethod
    def constant(value: float) -> Schedule:
        return Schedule((0.0,), (float(value),))

    @staticmethod
    def parse(text: str, name: str = "schedule", low: float = 0.0, high: float = 1.0) -> Schedule:
        """'0.7' or '0:0,2:1' (seconds:value pairs, times from 0 s and increasing); values must lie in
        [low, high]. A `ConfigError` names the option `name` (its Python name)."""
        try:
            if ":" not in text:
                schedule = Schedule.constant(float(text))
            else:
                pairs = [item.split(":") for item in text.split(",")]
                schedule = Schedule(tuple(float(t) for t, _ in pairs), tuple(float(v) for _, v in pairs))
        except ValueError:
            raise ConfigError(
                f"{name}: cannot read {text!r}; give a number or 'SECONDS:VALUE,...' (no empty keyframe)",
                name,
            ) from None
        if not all(math.isfinite(t) and t >= 0 for t in schedule.times_s):
            raise ConfigError(f"{name}: keyframe times are seconds from 0, got {text!r}", name)
        if any(b <= a for a, b in zip(schedule.times_s, schedule.times_s[1:])):
            raise ConfigError(f"{name}: keyframe times must increase, got {text!r}", name)
        if not all(low <= v <= high for v in schedule.values):
            raise ConfigError(f"{name}: values must lie between {low:g} and {high:g}, got {text!r}", name)
        return schedule

    def at(self, times_s: FloatArray) -> FloatArray:
        return np.interp(times_s, self.times_s, self.values)

    @property
    def is_zero(self) -> bool:
        return all(v == 0 for v in self.values)
