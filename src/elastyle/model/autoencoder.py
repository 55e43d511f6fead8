"""Numpy forward pass of the autoencoder: two convolutions and their transposes (no torch needed).

Layout: time-major arrays, x (T, C) features, h (T, H) hidden, z (T, Z) latents. Convolutions use
'same' length with edge-replicated input for the encoder and zero padding for the transposed decoder,
exactly as `elastyle.train` does in torch.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from elastyle.core.smoothing import pad_edges
from elastyle.model.config import ModelConfig
from elastyle.types import AnyFloatArray, Float32Array, IntArray


class AutoencoderWeights(NamedTuple):
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
    padded = pad_edges(x, pad, kernel - 1 - pad)  # (T + K - 1, C_in)
    windows = sliding_window_view(padded, kernel, axis=0)  # (T, C_in, K)
    flat = windows.reshape(windows.shape[0], -1)  # (T, C_in * K)
    return flat @ weight.reshape(weight.shape[0], -1).T + bias


def _transpose_taps(weight: Float32Array) -> Float32Array:
    """Weight (C_out, C_in, K) as one matrix (C_out, K * C_in) for `_conv_transpose_same`."""
    return np.ascontiguousarray(weight.transpose(0, 2, 1)).reshape(weight.shape[0], -1)


def _conv_transpose_same(h: Float32Array, taps: Float32Array, kernel: int) -> Float32Array:
    """Transposed convolution of h (T, C_out) by weight taps (C_out, K * C_in) from `_transpose_taps`,
    zero padding K // 2 -> (T, C_in).

    y[t] = sum_k h[t + pad - k] W[:, :, k]: one product gives every frame's K contributions (T, K, C_in),
    which are added at their K offsets (no (T, C_out * K) copy of the input).
    """
    num_frames = h.shape[0]
    contributions = (h @ taps).reshape(num_frames, kernel, -1)  # (T, K, C_in)
    if kernel == 1:
        return contributions[:, 0]
    pad = kernel // 2
    out = np.zeros((num_frames + kernel - 1, contributions.shape[2]), dtype=contributions.dtype)
    for k in range(kernel):  # h[t] reaches y[t - pad + k]
        out[k : k + num_frames] += contributions[:, k]
    return out[pad : pad + num_frames]


def _conv_transpose_at(h: Float32Array, taps: Float32Array, kernel: int, frames: IntArray) -> Float32Array:
    """`_conv_transpose_same` at output frames (n,) only: y[t] = sum_k h[t + pad - k] W[:, :, k], one product
    of each frame's K input rows (n, K * C_out) with the taps (K * C_out, C_in) -> (n, C_in)."""
    pad = kernel // 2
    width = h.shape[1]
    padded = np.concatenate(
        [np.zeros((kernel - 1 - pad, width), h.dtype), h, np.zeros((pad, width), h.dtype)]
    )
    rows = frames[:, None] + (kernel - 1) - np.arange(kernel)  # (n, K): h[t + pad - k] in `padded`
    weights = (
        taps.reshape(width, kernel, -1).transpose(1, 0, 2).reshape(kernel * width, -1)
    )  # (K * C_out, C_in)
    return padded[rows].reshape(len(frames), -1) @ weights


class Autoencoder:
    """encode: normalised features (T, C) -> latents (T, Z); decode: latents -> features."""

    def __init__(self, config: ModelConfig, weights: AutoencoderWeights) -> None:
        self.config = config
        self.weights = weights
        second, first = (weights.conv2, weights.conv1) if config.tied else (weights.deconv2, weights.deconv1)
        assert second is not None and first is not None, "an untied model needs its decoder weights"
        self._decoder_taps = (_transpose_taps(second), _transpose_taps(first))  # (Z, H), (H, K * C)

    def encode(self, features: AnyFloatArray) -> Float32Array:
        w = self.weights
        hidden = np.maximum(_conv_same(features.astype(np.float32), w.conv1, w.bias1), 0.0)  # (T, H)
        return np.maximum(_conv_same(hidden, w.conv2, w.bias2), 0.0)  # (T, Z)

    def decode(self, latents: AnyFloatArray, frames: IntArray | None = None) -> Float32Array:
        """Latents (T, Z) -> features (T, C), or (n, C) at output frames (n,) only."""
        w = self.weights
        latents = latents.astype(np.float32)
        second, first = self._decoder_taps
        kernel = w.conv1.shape[2]

        def last_layer(hidden: Float32Array) -> Float32Array:
            if frames is None:
                return _conv_transpose_same(hidden, first, kernel)
            return _conv_transpose_at(hidden, first, kernel, frames)

        if self.config.tied:
            # the report's inverse: subtract the bias, then the transposed convolution with the same weights
            hidden = np.maximum(_conv_transpose_same(latents - w.bias2, second, 1), 0.0)  # (T, H)
            return last_layer(hidden - w.bias1)  # (T, C)
        assert w.debias2 is not None and w.debias1 is not None
        hidden = np.maximum(_conv_transpose_same(latents, second, 1) + w.debias2, 0.0)
        return last_layer(hidden) + w.debias1
