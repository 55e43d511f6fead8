"""Whitening and colouring of latent sequences (WCT, Li et al. 2017), and per-channel statistics (AdaIN).

Latents are (T, Z). Statistics are pooled over every frame of every clip given.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from elastyle.types import FloatArray


class LatentStats(NamedTuple):
    """mean (Z,), covariance (Z, Z), and its whitening / colouring matrices (Z, Z)."""

    mean: FloatArray
    covariance: FloatArray
    whitening: FloatArray
    colouring: FloatArray

    @staticmethod
    def of(latents: Sequence[FloatArray], eps: float = 1e-4) -> LatentStats:
        """Stats of latent sequences (T_i, Z); `eps` (relative to the mean variance) regularises dead channels."""
        stacked = np.concatenate([np.asarray(z, dtype=np.float64) for z in latents])  # (T, Z)
        mean = stacked.mean(axis=0)
        centred = stacked - mean
        covariance = centred.T @ centred / max(stacked.shape[0] - 1, 1)
        values, vectors = np.linalg.eigh(covariance)
        floor = eps * max(float(np.mean(np.maximum(values, 0))), 1e-12)
        values = np.maximum(values, 0) + floor
        whitening = vectors @ np.diag(values**-0.5) @ vectors.T  # E D^-1/2 E^T
        colouring = vectors @ np.diag(values**0.5) @ vectors.T  # E D^1/2 E^T
        return LatentStats(mean, covariance, whitening, colouring)

    def whiten(self, latents: FloatArray) -> FloatArray:
        return (latents - self.mean) @ self.whitening.T

    def colour(self, white: FloatArray) -> FloatArray:
        return white @ self.colouring.T + self.mean


def whiten_colour(content: FloatArray, content_stats: LatentStats, style_stats: LatentStats) -> FloatArray:
    """Give content latents (T, Z) the style's mean and covariance."""
    return style_stats.colour(content_stats.whiten(content))


def adain(
    content: FloatArray, content_latents: Sequence[FloatArray], style_latents: Sequence[FloatArray]
) -> FloatArray:
    """Give content latents (T, Z) the style's per-channel mean and standard deviation."""
    ours = np.concatenate(content_latents)
    theirs = np.concatenate(style_latents)
    scale = theirs.std(axis=0) / np.maximum(ours.std(axis=0), 1e-6)
    return (content - ours.mean(axis=0)) * scale + theirs.mean(axis=0)
