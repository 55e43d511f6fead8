# mypy: disable-error-code="index,arg-type,operator"
"""Training the autoencoder on any set of BVH clips: the only module that uses torch.

The report's recipe (METHOD.md section 3): Adam, batch 16, learning rate 1e-4, windows of 4 s sampled
uniformly, features normalised per channel; mirrored clips are added as augmentation. Clips are split
into training and held-out sets by take (whole files, never windows).
"""

from __future__ import annotations

import json
import logging
import math
import time
import zlib
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from elastyle.errors import ElastyleError, SkeletonMismatchError
from elastyle.features import FeatureSpec
from elastyle.io.dataset import ClipRef, dataset_label, find_clips
from elastyle.mirror import mirror
from elastyle.model.autoencoder import Autoencoder, AutoencoderWeights
from elastyle.model.config import ModelConfig
from elastyle.model.file import StyleModel, save_model
from elastyle.motion import Motion
from elastyle.types import FloatArray

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class TrainConfig:
    model: ModelConfig = field(default_factory=ModelConfig)
    batch_size: int = 16
    learning_rate: float = 1e-4
    lr_schedule: str = "constant"  # or "cosine" (to 5 % of the rate over the step budget)
    window_s: float = 4.0
    minutes: float | None = None
    steps: int | None = None
    seed: int = 0
    mirror_augment: bool = True
    holdout_every: int = 5  # every 5th take is held out (dataset takes with take % 5 == 0)
    checkpoint_every: int = 500
    fps: float | None = None  # default: the first clip's
    position_loss: float = 0.0  # weight of a forward-kinematics joint position (and velocity) loss
    position_scale: float = 10.0  # file units that count as 1 in that loss (10 cm here)


def is_held_out(clip: ClipRef, every: int) -> bool:
    """The take split: dataset takes numbered % every == 0; other files by a stable hash of the name."""
    label = dataset_label(clip)
    if label is not None:
        return label[2] % every == 0
    return zlib.crc32(Path(clip.name).name.encode()) % every == 0


def _read_resampled(task: tuple[ClipRef, float | None]) -> Motion:
    clip, fps = task
    motion, _ = clip.read()
    return motion if fps is None else motion.resample(fps)


def load_motions(clips: Sequence[ClipRef], fps: float | None, workers: int = 2) -> list[Motion]:
    """Read clips (in parallel), resampled to `fps`; all must share one skeleton."""
    tasks = [(clip, fps) for clip in clips]
    if len(tasks) > 8 and workers > 1:
        with ProcessPoolExecutor(workers) as pool:
            motions = list(pool.map(_read_resampled, tasks, chunksize=16))
    else:
        motions = [_read_resampled(t) for t in tasks]
    for clip, motion in zip(clips, motions):
        motions[0].skeleton.check_same(motion.skeleton, clips[0].name, clip.name)
    return motions


def _torch_autoencoder(config: ModelConfig, num_channels: int):  # type: ignore[no-untyped-def]
    import torch
    from torch import nn
    from torch.nn import functional

    class TorchAutoencoder(nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.conv1 = nn.Conv1d(num_channels, config.hidden_channels, config.kernel_frames)
            self.conv2 = nn.Conv1d(config.hidden_channels, config.latent_channels, 1)
            if not config.tied:
                self.deconv2 = nn.ConvTranspose1d(config.latent_channels, config.hidden_channels, 1)
                self.deconv1 = nn.ConvTranspose1d(
                    config.hidden_channels,
                    num_channels,
                    config.kernel_frames,
                    padding=config.kernel_frames // 2,
                )

        def encode(self, x: torch.Tensor) -> torch.Tensor:  # x (B, C, T)
            pad = config.kernel_frames // 2
            x = functional.pad(x, (pad, config.kernel_frames - 1 - pad), mode="replicate")
            return functional.relu(self.conv2(functional.relu(self.conv1(x))))  # (B, Z, T)

        def decode(self, z: torch.Tensor) -> torch.Tensor:
            pad = config.kernel_frames // 2
            if config.tied:
                hidden = functional.relu(
                    functional.conv_transpose1d(z - self.conv2.bias[None, :, None], self.conv2.weight)
                )
                return functional.conv_transpose1d(
                    hidden - self.conv1.bias[None, :, None], self.conv1.weight, padding=pad
                )
            return self.deconv1(functional.relu(self.deconv2(z)))

        def forward(self, x: torch.Tensor) -> torch.Tensor:
            return self.decode(self.encode(x))

        def numpy_weights(self) -> AutoencoderWeights:
            def array(p: torch.Tensor) -> np.ndarray:
                return p.detach().cpu().numpy().astype(np.float32)

            extra = {}
            if not config.tied:
                extra = dict(
                    deconv2=array(self.deconv2.weight),
                    debias2=array(self.deconv2.bias),
                    deconv1=array(self.deconv1.weight),
                    debias1=array(self.deconv1.bias),
                )
            return AutoencoderWeights(
                array(self.conv1.weight),
                array(self.conv1.bias),
                array(self.conv2.weight),
                array(self.conv2.bias),
                **extra,
            )

    return TorchAutoencoder()


def _torch_pose_positions(features, spec: FeatureSpec, mean: FloatArray, std: FloatArray):  # type: ignore[no-untyped-def]
    """Joint positions (B, T, J_pose, 3) relative to the path, in the heading frame, from normalised features (B, C, T)."""
    import torch

    x = features.permute(0, 2, 1) * torch.from_numpy(std.astype(np.float32)) + torch.from_numpy(
        mean.astype(np.float32)
    )
    joints = spec.pose_joints.tolist()
    count = len(joints)
    rotvec = x[..., : 3 * count].reshape(*x.shape[:2], count, 3)
    angle = torch.linalg.norm(rotvec, dim=-1, keepdim=True)
    half_sinc = 0.5 * torch.sinc(angle / (2 * math.pi))  # sin(a / 2) / a, safe at 0
    quat = torch.cat([torch.cos(angle / 2), rotvec * half_sinc], dim=-1)  # (B, T, J, 4) w first
    from elastyle.rotations import to_quat

    ref = torch.from_numpy(np.roll(to_quat(spec.reference_rotations[joints]), 1, axis=-1).astype(np.float32))
    quat = _quat_multiply(ref, quat)
    matrices = _quat_matrix(quat)  # (B, T, J, 3, 3)
    offsets = torch.from_numpy(spec.skeleton.offsets[joints].astype(np.float32))
    root = torch.stack(
        [x[..., 3 * count], x[..., 3 * count + 2], x[..., 3 * count + 1]], dim=-1
    )  # sway x, height, sway z
    index = {joint: k for k, joint in enumerate(joints)}
    world = [matrices[:, :, 0]]
    positions = [root]
    for k in range(1, count):
        parent = index[int(spec.skeleton.parents[joints[k]])]
        world.append(world[parent] @ matrices[:, :, k])
        positions.append(positions[parent] + (world[parent] @ offsets[k, :, None])[..., 0])
    return torch.stack(positions, dim=2)


def _quat_multiply(a, b):  # type: ignore[no-untyped-def]
    import torch

    aw, ax, ay, az = a.unbind(-1)
    bw, bx, by, bz = b.unbind(-1)
    return torch.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        dim=-1,
    )


def _quat_matrix(q):  # type: ignore[no-untyped-def]
    import torch

    w, x, y, z = q.unbind(-1)
    return torch.stack(
        [
            1 - 2 * (y * y + z * z),
            2 * (x * y - z * w),
            2 * (x * z + y * w),
            2 * (x * y + z * w),
            1 - 2 * (x * x + z * z),
            2 * (y * z - x * w),
            2 * (x * z - y * w),
            2 * (y * z + x * w),
            1 - 2 * (x * x + y * y),
        ],
        dim=-1,
    ).reshape(*q.shape[:-1], 3, 3)


def _windows(features: list[FloatArray], window: int, count: int, rng: np.random.Generator) -> FloatArray:
    """`count` windows (B, C, W) sampled uniformly over all start frames of all clips."""
    starts_per_clip = np.array([max(f.shape[0] - window + 1, 0) for f in features])
    cumulative = np.cumsum(starts_per_clip)
    picks = rng.integers(0, cumulative[-1], size=count)
    clip_index = np.searchsorted(cumulative, picks, side="right")
    batch = []
    for pick, index in zip(picks, clip_index):
        start = pick - (cumulative[index] - starts_per_clip[index])
        batch.append(features[index][start : start + window])
    return np.stack(batch).transpose(0, 2, 1)  # (B, C, W)


def train(
    data: Sequence[str],
    output: str,
    config: TrainConfig,
    resume: str | None = None,
    force: bool = False,
    progress: bool = True,
) -> StyleModel:
    """Train a model on the clips that `data` names and write it to `output`; returns the model."""
    import torch

    torch.manual_seed(config.seed)
    rng = np.random.default_rng(config.seed)
    clips = find_clips(data)
    held_out = [c for c in clips if is_held_out(c, config.holdout_every)]
    training = [c for c in clips if not is_held_out(c, config.holdout_every)]
    if not training:
        training, held_out = held_out, []
    log.info("clips: %d for training, %d held out (by take)", len(training), len(held_out))
    fps = config.fps
    if fps is None:
        fps = training[0].read()[0].fps
    train_motions = load_motions(training, fps)
    val_motions = load_motions(held_out, fps) if held_out else []
    skeleton = train_motions[0].skeleton
    for clip, motion in zip(held_out, val_motions):
        skeleton.check_same(motion.skeleton, training[0].name, clip.name)
    if config.mirror_augment:
        try:
            train_motions = train_motions + [mirror(m) for m in train_motions]
        except SkeletonMismatchError:
            log.warning("no left/right joint pairs: training without mirrored clips")
    spec = FeatureSpec.fit(train_motions[:: max(1, len(train_motions) // 400)])
    train_features = [spec.encode(m)[0] for m in train_motions]
    val_features = [spec.encode(m)[0] for m in val_motions]
    stacked = np.concatenate(train_features)
    mean = stacked.mean(axis=0)
    std = np.maximum(stacked.std(axis=0), 1e-2)  # constant channels (unused joints) stay finite
    window = max(2, min(int(round(config.window_s * fps)), min(f.shape[0] for f in train_features)))
    train_norm = [((f - mean) / std).astype(np.float32) for f in train_features]
    val_norm = [((f - mean) / std).astype(np.float32) for f in val_features if f.shape[0] >= window]

    network = _torch_autoencoder(config.model, spec.num_channels)
    optimizer = torch.optim.Adam(network.parameters(), lr=config.learning_rate)
    step = 0
    elapsed_before = 0.0
    checkpoint_path = Path(str(output) + ".ckpt")
    if resume:
        state = torch.load(resume, weights_only=True)
        network.load_state_dict(state["network"])
        optimizer.load_state_dict(state["optimizer"])
        step = int(state["step"])
        elapsed_before = float(state["elapsed_s"])
        rng = np.random.default_rng(config.seed + step)
        log.info("resumed from %s at step %d", resume, step)
    budget_steps = config.steps if config.steps is not None else 10**9
    budget_s = config.minutes * 60 if config.minutes is not None else math.inf
    if config.steps is None and config.minutes is None:
        raise ElastyleError("give a training budget: --minutes or --steps")
    val_batch = (
        torch.from_numpy(_windows(val_norm, window, 64, np.random.default_rng(1))) if val_norm else None
    )

    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=config.steps, initial=step, unit="step", dynamic_ncols=True)
    started = time.perf_counter()
    val_loss = float("nan")
    train_loss = float("nan")
    while step < budget_steps and elapsed_before + time.perf_counter() - started < budget_s:
        if config.lr_schedule == "cosine":
            fraction = (
                step / budget_steps
                if config.steps
                else (elapsed_before + time.perf_counter() - started) / budget_s
            )
            rate = config.learning_rate * (0.05 + 0.95 * 0.5 * (1 + math.cos(math.pi * min(fraction, 1.0))))
            for group in optimizer.param_groups:
                group["lr"] = rate
        batch = torch.from_numpy(_windows(train_norm, window, config.batch_size, rng))
        reconstruction = network(batch)
        loss = torch.mean((reconstruction - batch) ** 2)
        if config.position_loss > 0:
            predicted = _torch_pose_positions(reconstruction, spec, mean, std) / config.position_scale
            target = _torch_pose_positions(batch, spec, mean, std) / config.position_scale
            position_error = torch.mean((predicted - target) ** 2)
            velocity_error = torch.mean((torch.diff(predicted, dim=1) - torch.diff(target, dim=1)) ** 2) * fps
            loss = loss + config.position_loss * (position_error + velocity_error)
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        step += 1
        train_loss = float(loss.detach())
        if step % 100 == 0 and val_batch is not None:
            with torch.no_grad():
                val_loss = float(torch.mean((network(val_batch) - val_batch) ** 2))
        if bar is not None:
            bar.update(1)
            bar.set_postfix(loss=f"{train_loss:.4f}", val=f"{val_loss:.4f}")
        if step % config.checkpoint_every == 0:
            _save_checkpoint(
                checkpoint_path, network, optimizer, step, elapsed_before + time.perf_counter() - started
            )
    if bar is not None:
        bar.close()
    elapsed = elapsed_before + time.perf_counter() - started
    _save_checkpoint(checkpoint_path, network, optimizer, step, elapsed)
    if val_batch is not None:
        with torch.no_grad():
            val_loss = float(torch.mean((network(val_batch) - val_batch) ** 2))
    metadata = {
        "train_config": json.loads(json.dumps(asdict(config))),
        "steps": step,
        "training_minutes": round(elapsed / 60, 2),
        "final_train_loss": train_loss,
        "held_out_loss": val_loss,
        "training_clips": len(training),
        "held_out_clips": len(held_out),
        "split": f"held out: takes numbered % {config.holdout_every} == 0 (other names: crc32 % {config.holdout_every} == 0)",
    }
    model = StyleModel(
        config.model,
        spec,
        mean,
        std,
        Autoencoder(config.model, network.numpy_weights()),
        float(fps),
        metadata,
    )
    save_model(output, model, force=force)
    log.info("wrote %s after %d steps (%.1f min), held-out loss %.4f", output, step, elapsed / 60, val_loss)
    return model


def _save_checkpoint(path: Path, network, optimizer, step: int, elapsed_s: float) -> None:  # type: ignore[no-untyped-def]
    import torch

    temporary = path.with_suffix(".tmp")
    torch.save(
        {
            "network": network.state_dict(),
            "optimizer": optimizer.state_dict(),
            "step": step,
            "elapsed_s": elapsed_s,
        },
        temporary,
    )
    temporary.replace(path)
