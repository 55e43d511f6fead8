"""The learning rate over a training budget: constant, or a cosine decay to `FLOOR` of the rate, which a
resumed run continues from where its checkpoint left it instead of starting the decay again."""

from __future__ import annotations

import math
from typing import NamedTuple

from elastyle.training.config import TrainConfig

FLOOR = 0.05  # the cosine schedule ends at this share of the learning rate


class LearningRate(NamedTuple):
    """rate: the learning rate at the budget's start; cosine: decay it (else constant).

    A resumed run maps its own budget's remaining fraction onto what its checkpoint had left: reached, the
    fraction of the checkpoint's budget spent when it was written; resumed_at, the same moment as a
    fraction of this run's budget. With the same budget the two are equal and the decay is the one an
    uninterrupted run has; with a larger one the rate goes on falling from where it was, over the added
    budget (before, it rose again, as if the run started over part-way); a run resumed after its budget
    was spent trains on at the floor.
    """

    rate: float
    cosine: bool
    reached: float = 0.0
    resumed_at: float = 0.0

    def at(self, fraction: float) -> float:
        """The learning rate when `fraction` (0 to 1) of this run's budget is spent (steps or seconds)."""
        if not self.cosine:
            return self.rate
        return self.rate * (
            FLOOR + (1 - FLOOR) * 0.5 * (1 + math.cos(math.pi * self.schedule_fraction(fraction)))
        )

    def schedule_fraction(self, fraction: float) -> float:
        """How far through the decay (0 to 1) the schedule is at `fraction` of this run's budget."""
        reached = min(self.reached, 1.0)
        if self.resumed_at >= 1 or reached >= 1:
            return 1.0
        remaining = (min(fraction, 1.0) - self.resumed_at) / (1 - self.resumed_at)
        return reached + (1 - reached) * max(remaining, 0.0)


def spent_fraction(config: TrainConfig, step: int, elapsed_s: float) -> float:
    """The share of `config`'s budget spent at `step` after `elapsed_s` seconds of training (its steps,
    else its minutes)."""
    if config.steps is not None:
        return step / config.steps if config.steps > 0 else 1.0
    budget_s = (config.minutes or 0.0) * 60
    return elapsed_s / budget_s if budget_s > 0 else 1.0
