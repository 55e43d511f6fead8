"""Whitening and colouring of latent sequences (WCT, Li et al. 2017), and per-channel statistics (AdaIN).

Latents are (T, Z). Statistics are pooled over every frame of every clip given.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from elastyle.types import FloatArray


class LatentStats(NamedTuple):
    """mean (Z,), covariance (Z, Z), and the covariance's eigenvalues (Z,) and eigenvectors (Z, Z)."""

    mean: FloatArray
    covariance: FloatArray
    eigenvalues: FloatArray
    eigenvectors: FloatArray

    @staticmethod
    def of(latents: Sequence[FloatArray]) -> LatentStats:
        """Stats of latent sequences (T_i, Z), pooled over every frame."""
        stacked = np.concatenate([np.asarray(z, dtype=np.float64) for z in latents])  # (T, Z)
        mean = stacked.mean(axis=0)
        centred = stacked - mean
        covariance = centred.T @ centred / max(stacked.shape[0] - 1, 1)
        values, vectors = np.linalg.eigh(covariance)
        return LatentStats(mean, covariance, np.maximum(values, 0.0), vectors)

    def _power(self, exponent: float, floor: float) -> FloatArray:
        """E (D + floor * mean(D))^exponent E^T (Z, Z): `floor` keeps directions that hardly vary from being
        amplified by whitening (docs/method.md, "Whitening floor")."""
        values = self.eigenvalues + floor * max(float(np.mean(self.eigenvalues)), 1e-12)
        return (self.eigenvectors * values**exponent) @ self.eigenvectors.T

    def whiten(self, latents: FloatArray, floor: float) -> FloatArray:
        """Latents (T, Z) centred and decorrelated to unit variance (above the floor)."""
        return (latents - self.mean) @ self._power(-0.5, floor).T

    def colour(self, white: FloatArray, floor: float) -> FloatArray:
        """Whitened latents (T, Z) given these statistics."""
        return white @ self._power(0.5, floor).T + self.mean


def adain(
    content: FloatArray, content_latents: Sequence[FloatArray], style_latents: Sequence[FloatArray]
) -> FloatArray:
    """Give content latents (T, Z) the style's per-channel mean and standard deviation."""
    ours = np.concatenate(content_latents)
    theirs = np.concatenate(style_latents)
    scale = theirs.std(axis=0) / np.maximum(ours.std(axis=0), 1e-6)
    return (content - ours.mean(axis=0)) * scale + theirs.mean(axis=0)
