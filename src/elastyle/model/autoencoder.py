"""Numpy forward pass of the autoencoder: two convolutions and their transposes (no torch needed).

Layout: time-major arrays, x (T, C) features, h (T, H) hidden, z (T, Z) latents. Convolutions use
'same' length with edge-replicated input for the encoder and zero padding for the transposed decoder,
exactly as `elastyle.train` does in torch.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from elastyle.model.config import ModelConfig
from elastyle.types import AnyFloatArray, Float32Array


@dataclass(frozen=True, eq=False)
class AutoencoderWeights:
    """Weights in torch's layout.

    conv1: (H, C, K), bias1: (H,); conv2: (Z, H, 1), bias2: (Z,).
    Untied decoders add deconv2: (Z, H, 1), debias2: (H,), deconv1: (H, C, K), debias1: (C,).
    """

    conv1: Float32Array
    bias1: Float32Array
    conv2: Float32Array
    bias2: Float32Array
    deconv2: Float32Array | None = None
    debias2: Float32Array | None = None
    deconv1: Float32Array | None = None
    debias1: Float32Array | None = None


def _conv_same(x: Float32Array, weight: Float32Array, bias: Float32Array) -> Float32Array:
    """Correlate x (T, C_in) with weight (C_out, C_in, K), edge-replicated to keep T frames -> (T, C_out)."""
    kernel = weight.shape[2]
    if kernel == 1:
        return x @ weight[:, :, 0].T + bias
    pad = kernel // 2
    padded = np.pad(x, ((pad, kernel - 1 - pad), (0, 0)), mode="edge")  # (T + K - 1, C_in)
    windows = sliding_window_view(padded, kernel, axis=0)  # (T, C_in, K)
    flat = windows.reshape(windows.shape[0], -1)  # (T, C_in * K)
    return flat @ weight.reshape(weight.shape[0], -1).T + bias


def _conv_transpose_same(h: Float32Array, weight: Float32Array) -> Float32Array:
    """Transposed convolution of h (T, C_out) by weight (C_out, C_in, K), zero padding K // 2 -> (T, C_in)."""
    kernel = weight.shape[2]
    if kernel == 1:
        return h @ weight[:, :, 0]
    pad = kernel // 2
    # y[t] = sum_k h[t + pad - k] W[:, :, k]: a correlation with the kernel flipped in time
    padded = np.pad(h, ((kernel - 1 - pad, pad), (0, 0)))  # (T + K - 1, C_out)
    windows = sliding_window_view(padded, kernel, axis=0)  # (T, C_out, K)
    flipped = weight[:, :, ::-1]  # (C_out, C_in, K)
    return windows.reshape(windows.shape[0], -1) @ flipped.transpose(0, 2, 1).reshape(-1, weight.shape[1])


class Autoencoder:
    """encode: normalised features (T, C) -> latents (T, Z); decode: latents -> features."""

    def __init__(self, config: ModelConfig, weights: AutoencoderWeights) -> None:
        self.config = config
        self.weights = weights

    def encode(self, features: AnyFloatArray) -> Float32Array:
        w = self.weights
        hidden = np.maximum(_conv_same(features.astype(np.float32), w.conv1, w.bias1), 0.0)  # (T, H)
        return np.maximum(_conv_same(hidden, w.conv2, w.bias2), 0.0)  # (T, Z)

    def decode(self, latents: AnyFloatArray) -> Float32Array:
        w = self.weights
        latents = latents.astype(np.float32)
        if self.config.tied:
            # the report's inverse: subtract the bias, then the transposed convolution with the same weights
            hidden = np.maximum(_conv_transpose_same(latents - w.bias2, w.conv2), 0.0)  # (T, H)
            return _conv_transpose_same(hidden - w.bias1, w.conv1)  # (T, C)
        assert (
            w.deconv2 is not None
            and w.debias2 is not None
            and w.deconv1 is not None
            and w.debias1 is not None
        )
        hidden = np.maximum(_conv_transpose_same(latents, w.deconv2) + w.debias2, 0.0)
        return _conv_transpose_same(hidden, w.deconv1) + w.debias1
