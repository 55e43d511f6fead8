"""Model configuration: the report's architecture by default (docs/method.md, "Autoencoder")."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ModelConfig:
    """Conv1d(C -> hidden, kernel) + ReLU, Conv1d(hidden -> latent, 1) + ReLU, and its decoder.

    tied: the decoder reuses the encoder's weights and biases as its inverse (the report's form);
    False gives the decoder weights of its own (same shapes).
    """

    hidden_channels: int = 256
    latent_channels: int = 32
    kernel_frames: int = 15
    tied: bool = True
