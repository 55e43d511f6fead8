"""Style and content recognition: ridge classifiers on clip descriptors, trained on real dataset clips.

A clip's descriptor is the mean and standard deviation over time of its pose features (joint rotations
relative to the model's references, pelvis sway and height) and of its travel (forward, sideways and
turning), plus its cadence and arm-swing frequency.
The classifier is one-vs-rest ridge regression on standardised descriptors: small, deterministic, numpy.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from elastyle.core.motion import Motion
from elastyle.eval.metrics import arm_swing_hz, cadence_steps_s
from elastyle.model.features import FeatureSpec
from elastyle.steps.action import action_channels
from elastyle.types import FloatArray


def describe(motion: Motion, spec: FeatureSpec) -> FloatArray:
    """Descriptor (2C + 8,) of a clip: its pose features' mean and standard deviation, its travel's
    (forward, sideways, turning: `steps.action`) too, then its cadence and arm-swing frequency."""
    features, _ = spec.encode(motion)
    travel = action_channels(motion)[:, :3]  # (T, 3) legs/s and rad/s, in the heading frame
    rhythm = np.nan_to_num([cadence_steps_s(motion), arm_swing_hz(motion)])
    return np.concatenate(
        [features.mean(axis=0), features.std(axis=0), travel.mean(axis=0), travel.std(axis=0), rhythm]
    )


@dataclass(frozen=True, eq=False)
class RidgeClassifier:
    labels: tuple[str, ...]
    mean: FloatArray
    scale: FloatArray
    weights: FloatArray  # (D + 1, K)

    @staticmethod
    def fit(descriptors: FloatArray, labels: Sequence[str], ridge: float = 1.0) -> RidgeClassifier:
        classes = tuple(sorted(set(labels)))
        mean = descriptors.mean(axis=0)
        scale = np.maximum(descriptors.std(axis=0), 1e-6)
        x = np.hstack([(descriptors - mean) / scale, np.ones((len(descriptors), 1))])
        targets = np.array([[1.0 if label == c else -1.0 for c in classes] for label in labels])
        weights = np.linalg.solve(x.T @ x + ridge * np.eye(x.shape[1]), x.T @ targets)
        return RidgeClassifier(classes, mean, scale, weights)

    def predict(self, descriptors: FloatArray) -> list[str]:
        x = np.hstack([(descriptors - self.mean) / self.scale, np.ones((len(descriptors), 1))])
        return [self.labels[i] for i in np.argmax(x @ self.weights, axis=1)]

    def accuracy(self, descriptors: FloatArray, labels: Sequence[str]) -> float:
        return float(np.mean([p == t for p, t in zip(self.predict(descriptors), labels)]))
