"""The autoencoder in torch, for training only: the same layers as `elastyle.model.autoencoder`'s numpy
forward pass (a test checks they agree), and the forward kinematics of the position loss.

Quaternions here are scalar-last (x, y, z, w), through the same helpers as everywhere else in elastyle.
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn
from torch.nn import functional

from elastyle.core.rotations import quat_multiply, quat_to_matrix, to_quat
from elastyle.model.autoencoder import AutoencoderWeights
from elastyle.model.config import ModelConfig
from elastyle.model.features import FeatureSpec
from elastyle.types import FloatArray


class TorchAutoencoder(nn.Module):
    """Conv1d(C -> H, K) + ReLU, Conv1d(H -> Z, 1) + ReLU; tied (the report's inverse) or untied decoder.

    Tensors are (B, C, T) features and (B, Z, T) latents.
    """

    def __init__(self, config: ModelConfig, num_channels: int) -> None:
        super().__init__()
        self.config = config
        self.conv1 = nn.Conv1d(num_channels, config.hidden_channels, config.kernel_frames)
        self.conv2 = nn.Conv1d(config.hidden_channels, config.latent_channels, 1)
        if not config.tied:
            self.deconv2 = nn.ConvTranspose1d(config.latent_channels, config.hidden_channels, 1)
            self.deconv1 = nn.ConvTranspose1d(
                config.hidden_channels, num_channels, config.kernel_frames, padding=config.kernel_frames // 2
            )

    def encode(self, x: torch.Tensor) -> torch.Tensor:
        kernel = self.config.kernel_frames
        x = functional.pad(x, (kernel // 2, kernel - 1 - kernel // 2), mode="replicate")
        return functional.relu(self.conv2(functional.relu(self.conv1(x))))

    def decode(self, z: torch.Tensor) -> torch.Tensor:
        if not self.config.tied:
            return self.deconv1(functional.relu(self.deconv2(z)))
        hidden = functional.relu(
            functional.conv_transpose1d(z - _bias(self.conv2)[None, :, None], self.conv2.weight)
        )
        return functional.conv_transpose1d(
            hidden - _bias(self.conv1)[None, :, None],
            self.conv1.weight,
            padding=self.config.kernel_frames // 2,
        )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.decode(self.encode(x))

    def numpy_weights(self) -> AutoencoderWeights:
        def array(parameter: torch.Tensor) -> np.ndarray:
            return parameter.detach().cpu().numpy().astype(np.float32)

        decoder = {}
        if not self.config.tied:
            decoder = {
                "deconv2": array(self.deconv2.weight),
                "debias2": array(_bias(self.deconv2)),
                "deconv1": array(self.deconv1.weight),
                "debias1": array(_bias(self.deconv1)),
            }
        return AutoencoderWeights(
            array(self.conv1.weight), array(_bias(self.conv1)), array(self.conv2.weight), array(_bias(self.conv2)),
            **decoder,
        )  # fmt: skip


def _bias(layer: nn.Conv1d | nn.ConvTranspose1d) -> torch.Tensor:
    """A layer's bias (every layer here has one)."""
    assert layer.bias is not None
    return layer.bias


def _stack_last(parts: list[torch.Tensor]) -> torch.Tensor:
    return torch.stack(parts, dim=-1)


class PosePositions:
    """Joint positions (B, T, J_pose, 3) relative to the path, in the heading frame, from normalised
    features (B, C, T): what the position loss compares (file units)."""

    def __init__(self, spec: FeatureSpec, mean: FloatArray, std: FloatArray) -> None:
        joints = spec.pose_joints.tolist()
        self.count = len(joints)
        self.mean = torch.from_numpy(mean.astype(np.float32))
        self.std = torch.from_numpy(std.astype(np.float32))
        self.reference = torch.from_numpy(to_quat(spec.reference_rotations[joints]).astype(np.float32))
        self.offsets = torch.from_numpy(spec.skeleton.offsets[joints].astype(np.float32))
        index = {joint: k for k, joint in enumerate(joints)}
        self.parents = [index[int(spec.skeleton.parents[j])] if k else -1 for k, j in enumerate(joints)]

    def __call__(self, features: torch.Tensor) -> torch.Tensor:
        x = features.permute(0, 2, 1) * self.std + self.mean  # (B, T, C)
        count = self.count
        rotvec = x[..., : 3 * count].reshape(*x.shape[:2], count, 3)
        angle = torch.linalg.norm(rotvec, dim=-1, keepdim=True)
        half_sinc = 0.5 * torch.sinc(angle / (2 * np.pi))  # sin(a / 2) / a, safe at 0
        quats = torch.cat([rotvec * half_sinc, torch.cos(angle / 2)], dim=-1)  # (B, T, J, 4) xyzw
        matrices = quat_to_matrix(
            quat_multiply(self.reference, quats, _stack_last), _stack_last
        )  # (B, T, J, 3, 3)
        root = torch.stack([x[..., 3 * count], x[..., 3 * count + 2], x[..., 3 * count + 1]], dim=-1)
        world = [matrices[:, :, 0]]
        positions = [root]  # sway x, height, sway z
        for k in range(1, count):
            parent = self.parents[k]
            world.append(world[parent] @ matrices[:, :, k])
            positions.append(positions[parent] + (world[parent] @ self.offsets[k, :, None])[..., 0])
        return torch.stack(positions, dim=2)
