"""How to train: the step budget, the optimiser and the augmentations (no torch needed to read it)."""

from __future__ import annotations

from dataclasses import dataclass, field

from elastyle.io.dataset import HOLDOUT_EVERY
from elastyle.model.config import ModelConfig


@dataclass(frozen=True)
class TrainConfig:
    """The report's recipe by default (docs/method.md, "Training"), plus the augmentations that widen the
    pose space beyond the recorded clips.

    window_s: length of a training window, seconds (short clips, such as one raise of a hand, must fit).
    reverse_augment: share of windows played backwards (a backward walk from a forward one).
    speed_augment: share of batches resampled in time by a factor drawn log-uniformly from speed_range
        (0.5 = half speed, 2 = twice as fast).
    perturb_augment: share of windows whose joints get random offsets (`perturb_scale` standard deviations,
        drifting over the window) within the recorded ranges: poses no clip holds.
    position_loss: weight of a forward-kinematics joint position and velocity loss; position_scale is the
        length (centimetres, whatever the rig's unit) that counts as 1 in it.
    """

    model: ModelConfig = field(default_factory=ModelConfig)
    batch_size: int = 16
    learning_rate: float = 1e-4
    lr_schedule: str = "constant"  # or "cosine" (to 5 % of the rate over the budget)
    window_s: float = 4.0
    minutes: float | None = None
    steps: int | None = None
    seed: int = 0
    mirror_augment: bool = True
    reverse_augment: float = 0.0
    speed_augment: float = 0.0
    speed_range: tuple[float, float] = (0.5, 2.0)
    perturb_augment: float = 0.0
    perturb_scale: float = 0.5
    holdout_every: int = HOLDOUT_EVERY
    checkpoint_every: int = 500
    fps: float | None = None  # default: the first clip's
    position_loss: float = 0.0
    position_scale: float = 10.0


# Named recipes: the report's (TrainConfig's defaults) and the one the shipped model was trained with
# (MODEL_CARD.md; chosen by the leave-content-out study in README.md); the shipped model's budget (44
# minutes) is not part of its recipe.
RECIPES: dict[str, TrainConfig] = {
    "report": TrainConfig(),
    "shipped": TrainConfig(
        model=ModelConfig(latent_channels=64, tied=False),
        batch_size=32,
        learning_rate=1e-3,
        lr_schedule="cosine",
        window_s=2.0,
        reverse_augment=0.3,
        speed_augment=0.5,
        perturb_augment=1.0,
        perturb_scale=1.0,
        position_loss=1.0,
    ),
}
