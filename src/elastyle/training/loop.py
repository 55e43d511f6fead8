"""The training loop: the only code that runs torch (imported when `train` is called).

The report's recipe (docs/method.md, "Training"): Adam, batch 16, learning rate 1e-4, windows sampled
uniformly, features normalised per channel; mirrored clips, backward playback and speed changes are added
as augmentation. Clips are split into training and held-out sets by take (whole files, never windows).
"""

from __future__ import annotations

import fnmatch
import json
import logging
import math
import os
import shlex
import time
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path

import numpy as np

from elastyle import __version__
from elastyle.core.body import centimetres_per_unit
from elastyle.core.mirror import mirror
from elastyle.errors import ElastyleError, SkeletonMismatchError
from elastyle.io.dataset import ClipRef, find_clips, is_held_out, read_up, split_held_out
from elastyle.model.autoencoder import Autoencoder
from elastyle.model.depth import DEFAULT_WARN_CM, calibrate
from elastyle.model.features import FeatureSpec
from elastyle.model.file import StyleModel, save_model
from elastyle.training.checkpoint import StopOnInterrupt, read_checkpoint, recorded_config, save_checkpoint
from elastyle.training.clips import at_one_size, load_motions, on_one_skeleton
from elastyle.training.config import TrainConfig
from elastyle.training.rate import LearningRate, spent_fraction
from elastyle.training.windows import draw_speed, perturb_windows, sample_windows

log = logging.getLogger(__name__)


FEW_CLIPS = 5  # fewer training clips than this get a warning
PROGRESS_LINE_S = 30.0  # without a progress bar (not a terminal), a line at least this often


def _named(clip: ClipRef, pattern: str) -> bool:
    """Whether glob `pattern` matches the clip's file name, with or without its extension, or its path (the
    whole of it or its end: `folder/name.bvh`)."""
    path = clip.member or clip.name
    names = (clip.stem, os.path.basename(path), path)
    return any(fnmatch.fnmatch(name, pattern) for name in names) or fnmatch.fnmatch(path, f"*/{pattern}")


def train(
    data: Sequence[str],
    output: str,
    config: TrainConfig,
    resume: str | None = None,
    force: bool = False,
    progress: bool = True,
    exclude: Sequence[str] = (),
) -> StyleModel:
    """Train a model on the clips that `data` names (less those whose file name, without extension,
    matches a glob of `exclude`) and write it to `output`; returns the model."""
    import torch

    torch.manual_seed(config.seed)
    rng = np.random.default_rng(config.seed)
    # a clip named twice (its folder and itself, or two paths to one file) counts once
    found = {(os.path.realpath(c.archive or c.name), c.member): c for c in find_clips(data)}
    clips = [c for c in found.values() if not any(_named(c, p) for p in exclude)]
    if not clips:
        raise ElastyleError(f"{', '.join(map(str, data))}: every clip is excluded by {', '.join(exclude)}")
    for pattern in exclude:
        if not any(_named(c, pattern) for c in found.values()):
            log.warning(
                "warning: --exclude %s matches no clip (matched against each clip's file name, with or without "
                "its extension, and its path)", pattern,
            )  # fmt: skip
    if exclude:
        log.info("clips: %d of %d left out by --exclude", len(found) - len(clips), len(found))
    training, held_out = split_held_out(clips, config.holdout_every)
    clip_names = sorted(c.stem for c in training)  # recorded in checkpoints: a resume says if they differ
    if len(training) < FEW_CLIPS:
        log.warning(
            "warning: %d training clip(s): a model learns the motions it is shown, and so few teach it little "
            "of the rig's range (the shipped model saw 2,346); give it every kind of motion the rig performs",
            len(training),
        )  # fmt: skip
    log.info(
        "clips: %d for training, %d held out (takes numbered %% %d == 0, the number ending the file name; names "
        "without one, one in %d by checksum)", len(training), len(held_out), config.holdout_every, config.holdout_every,
    )  # fmt: skip
    if not held_out and any(is_held_out(c, config.holdout_every) for c in training):
        log.warning(
            "warning: every clip given is a held-out take (numbered %% %d == 0), so the model trains on them: "
            "`calibrate` or a test on them reads it better than it is; give it other takes too",
            config.holdout_every,
        )  # fmt: skip
    # read together, so every unreadable clip is named at once; at the first training clip's rate unless given
    motions = load_motions([*training, *held_out], config.fps)
    fps = config.fps or motions[0].fps
    motions = [m if m.fps == fps else m.resample(fps) for m in motions]
    train_motions, val_motions = motions[: len(training)], motions[len(training) :]
    skeleton = train_motions[0].skeleton
    val_motions = on_one_skeleton(skeleton, training[0].name, held_out, val_motions)
    train_motions, val_motions = at_one_size(train_motions, skeleton), at_one_size(val_motions, skeleton)
    # a clip shorter than the convolution holds no window the model can learn from
    kernel = config.model.kernel_frames
    short = sum(m.num_frames < kernel for m in [*train_motions, *val_motions])
    if short:
        log.warning(
            "note: %d clip(s) shorter than --kernel %d frames at %g fps are left out", short, kernel, fps
        )
        train_motions = [m for m in train_motions if m.num_frames >= kernel]
        val_motions = [m for m in val_motions if m.num_frames >= kernel]
    if not train_motions:
        raise ElastyleError(
            f"{', '.join(map(str, data))}: no training clip has --kernel {kernel} frames at {fps:g} fps; "
            "give longer clips"
        )
    lengths = [m.num_frames for m in train_motions]  # (clips,) frames of each training clip
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
    # a window as long as asked where clips allow, but never longer than the longest clip
    window = max(2, min(int(round(config.window_s * fps)), max(f.shape[0] for f in train_features)))
    if window < int(round(config.window_s * fps)):
        log.info(
            "note: the longest training clip is %.2f s, so windows are %.2f s instead of --window-s %g",
            window / fps, window / fps, config.window_s,
        )  # fmt: skip
    # a clip shorter than a window gives none: said, with what would train on it (clips of one loop or one
    # gesture, a second or two, were left out of a 4 s window in silence)
    unwindowed = [n for n in lengths if n < window]
    if unwindowed:
        shortest = max(min(unwindowed), kernel)
        log.warning(
            "note: %d of the %d training clips are shorter than the %.2f s windows (the shortest %.2f s) and are "
            "not trained on; --window-s %.2f trains on every one%s",
            len(unwindowed), len(lengths), window / fps, min(unwindowed) / fps, math.floor(100 * shortest / fps) / 100,
            " (--recipe shipped: 2 s windows)" if window / fps > 2 else "",
        )  # fmt: skip
    train_norm = [((f - mean) / std).astype(np.float32) for f in train_features]
    val_norm = [((f - mean) / std).astype(np.float32) for f in val_features if f.shape[0] >= window]
    longest = max(f.shape[0] for f in train_features)
    # per-joint perturbation: each joint's channels move together, within the recorded range
    groups = np.minimum(np.arange(spec.num_channels) // 3, spec.num_channels // 3 - 1)  # (C,) joint ids
    low, high = (((bound - mean) / std).astype(np.float32) for bound in (stacked.min(0), stacked.max(0)))

    from elastyle.training.network import PosePositions, TorchAutoencoder

    network = TorchAutoencoder(config.model, spec.num_channels)
    pose_positions = PosePositions(spec, mean, std)
    # the length that counts as 1 in the position loss, in the rig's units: the same weight in any unit (a
    # rig in metres trained without it, its positions 100 times smaller)
    position_scale = config.position_scale / centimetres_per_unit(skeleton)
    optimizer = torch.optim.Adam(network.parameters(), lr=config.learning_rate)
    step = resumed_at = 0
    elapsed_before = 0.0
    reached = None  # for a resumed run, the share of its checkpoint's own budget spent
    checkpoint_path = Path(str(output) + ".ckpt")
    if resume:
        state = read_checkpoint(resume)
        try:
            network.load_state_dict(state["network"])
            optimizer.load_state_dict(state["optimizer"])
        except (RuntimeError, ValueError, KeyError):
            settings = recorded_config(state)
            if (
                settings is not None and settings.model == config.model
            ):  # the same shape: the skeleton differs
                raise ElastyleError(
                    f"{resume}: a checkpoint trained on clips of another skeleton than these; resume it with the "
                    "clips it was trained on, or start over"
                ) from None
            raise ElastyleError(
                f"{resume}: a checkpoint of another model shape or skeleton; resume with the options it was "
                "trained with (--recipe, --hidden, --latent, --kernel, --untied, the same clips' skeleton), or "
                "start over"
            ) from None
        step = int(state["step"])
        resumed_at = step
        elapsed_before = float(state["elapsed_s"])
        settings = recorded_config(state)
        if settings is not None:
            reached = spent_fraction(settings, step, elapsed_before)
        rng = np.random.default_rng(config.seed + step)
        log.info("resumed from %s at step %d", resume, step)
        recorded = state.get("clip_names")
        if recorded is not None and list(recorded) != clip_names:
            log.warning(
                "warning: %s was trained on %d clip(s), these are %d (%d of them the same): training goes on "
                "with these, its normalisation read from them", resume, len(recorded), len(clip_names),
                len(set(recorded) & set(clip_names)),
            )  # fmt: skip
    budget_steps = config.steps if config.steps is not None else 10**9
    budget_s = config.minutes * 60 if config.minutes is not None else math.inf
    if config.steps is None and config.minutes is None:
        raise ElastyleError("give a training budget: --minutes or --steps")
    resumed_fraction = spent_fraction(config, step, elapsed_before)
    rates = LearningRate(
        config.learning_rate,
        config.lr_schedule == "cosine",
        resumed_fraction if reached is None else reached,
        resumed_fraction,
    )
    if resume and rates.cosine and rates.schedule_fraction(resumed_fraction) >= 1 and resumed_fraction < 1:
        log.info("note: %s ended its learning-rate decay: the added budget trains at its floor rate", resume)
    val_batch = (
        torch.from_numpy(sample_windows(val_norm, window, 64, np.random.default_rng(1))) if val_norm else None
    )

    bar = None
    if progress:
        from tqdm import tqdm

        if config.steps is not None:
            bar = tqdm(total=config.steps, initial=step, unit="step", dynamic_ncols=True, disable=None)
        else:  # a budget of minutes: the bar counts seconds, so it shows what is left
            bar = tqdm(
                total=round(budget_s),
                initial=round(elapsed_before),
                unit="s",
                dynamic_ncols=True,
                disable=None,
                bar_format="{l_bar}{bar}| {n:.0f}/{total:.0f} s [{elapsed}<{remaining}{postfix}]",
            )  # fmt: skip  (a terminal only, both)
    started = time.perf_counter()
    val_loss = float("nan")
    train_loss = float("nan")
    stop = StopOnInterrupt()  # Ctrl-C ends training after the step under way, with a checkpoint
    last_line_s = elapsed_before  # when the last progress line was said (seconds of training)
    try:
        while (
            step < budget_steps
            and elapsed_before + time.perf_counter() - started < budget_s
            and not stop.asked
        ):
            if rates.cosine:
                rate = rates.at(spent_fraction(config, step, elapsed_before + time.perf_counter() - started))
                for group in optimizer.param_groups:
                    group["lr"] = rate
            speed = min(draw_speed(rng, config.speed_augment, config.speed_range), longest / window)
            windows = sample_windows(
                train_norm, window, config.batch_size, rng, speed, config.reverse_augment
            )
            if config.perturb_augment > 0:
                windows = perturb_windows(
                    windows, config.perturb_augment, config.perturb_scale, groups, low, high, rng
                )
            batch = torch.from_numpy(windows)
            reconstruction = network(batch)
            loss = torch.mean((reconstruction - batch) ** 2)
            if config.position_loss > 0:
                predicted = pose_positions(reconstruction) / position_scale
                target = pose_positions(batch) / position_scale
                position_error = torch.mean((predicted - target) ** 2)
                velocity_error = (
                    torch.mean((torch.diff(predicted, dim=1) - torch.diff(target, dim=1)) ** 2) * fps
                )
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
                spent_s = min(
                    elapsed_before + time.perf_counter() - started, budget_s
                )  # seconds, for the bar
                done = 1 if config.steps is not None else spent_s - bar.n
                bar.update(done)
                shown = {"step": step, "loss": f"{train_loss:.4f}"}
                if math.isfinite(val_loss):
                    shown["held_out"] = f"{val_loss:.4f}"
                bar.set_postfix(shown, refresh=False)
            spent = elapsed_before + time.perf_counter() - started
            saved = step % config.checkpoint_every == 0 and save_checkpoint(
                checkpoint_path, network, optimizer, step, spent, config, clip_names, required=False
            )
            # no bar (not a terminal): a line per checkpoint, and at least every `PROGRESS_LINE_S`
            if (bar is None or bar.disable) and (saved or spent - last_line_s >= PROGRESS_LINE_S):
                last_line_s = spent
                held = f", held-out {val_loss:.4f}" if math.isfinite(val_loss) else ""
                log.info(
                    "step %d, %.1f min: loss %.4f%s%s",
                    step, spent / 60, train_loss, held, f" (checkpoint {checkpoint_path})" if saved else "",
                )  # fmt: skip
    finally:
        stop.release()
    if bar is not None:
        bar.close()
    elapsed = elapsed_before + time.perf_counter() - started
    # the checkpoint is what an interrupted training leaves, so it must be written; at the end the model is
    # what counts, written even where its checkpoint cannot be
    checkpointed = save_checkpoint(
        checkpoint_path, network, optimizer, step, elapsed, config, clip_names, required=stop.asked
    )
    if stop.asked:
        budget = f"--minutes {config.minutes:g}" if config.minutes is not None else f"--steps {config.steps}"
        # the same clips, read the same way, into the same file
        same = [*(f"--exclude {shlex.quote(pattern)}" for pattern in exclude)]
        same += [f"--up {read_up()}"] if read_up() != "auto" else []
        same += ["--force"] if force else []
        given = " ".join(shlex.quote(str(spec)) for spec in data)
        log.warning(
            "interrupted at step %d: the training so far is in %s; continue it with `elastyle train %s -o %s "
            "--resume %s %s` (the same clips and options; the budget counts the training so far, so raise it "
            "to train longer)", step, checkpoint_path, given, shlex.quote(output),
            " ".join([shlex.quote(str(checkpoint_path)), *same]), budget,
        )  # fmt: skip
        raise KeyboardInterrupt
    if val_batch is not None:
        with torch.no_grad():
            val_loss = float(torch.mean((network(val_batch) - val_batch) ** 2))
    metadata = {
        "train_config": json.loads(json.dumps(asdict(config))),
        "steps": step,
        "training_minutes": round(elapsed / 60, 2),
        "window_frames": window,  # as trained: at most --window-s, never longer than the longest clip
        "final_train_loss": train_loss,
        "held_out_loss": val_loss if math.isfinite(val_loss) else None,  # None: no clip was held out
        "training_clips": len(lengths) - len(unwindowed),  # those that gave windows
        "held_out_clips": len(held_out),
        # where it comes from: the clips as named to train (their last path part: no folder of the user's
        # goes out with a model shared), less those excluded, when, by which version
        "data": [Path(str(spec).rstrip("/\\")).name or str(spec) for spec in data],
        "excluded": list(exclude),
        "trained_utc": time.strftime("%Y-%m-%d %H:%M", time.gmtime()),
        "elastyle_version": __version__,
        "split": f"held out: takes numbered % {config.holdout_every} == 0, the number ending the file name (other "
        f"names: crc32 % {config.holdout_every} == 0)",
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
    # what it reaches on held-out takes, so a transfer can tell a clip it cannot represent
    metadata.update(calibrate(model, val_motions[:: max(1, len(val_motions) // 300)]))
    save_model(output, model, force=force)
    measured = (
        f"held-out loss {val_loss:.4f}"
        if math.isfinite(val_loss)
        else "no held-out clip as long as a window for a held-out loss"
        if val_motions
        else "no clip held out to measure it"
    )
    resumes = (
        f"{checkpoint_path} resumes it for a longer training (--resume), or can be deleted"
        if checkpointed
        else "no checkpoint to resume it from"
    )
    log.info(
        "wrote %s after %d step%s (%.1f min), %s; %s", output, step, "" if step == 1 else "s", elapsed / 60,
        measured, resumes,
    )  # fmt: skip
    if "reconstruction_warn_cm" not in metadata:
        log.warning(
            "note: %s: with no held-out clip to measure it on, its out-of-depth warning uses the default %.1f "
            "cm; measure it on clips it was not trained on with 'elastyle calibrate %s CLIPS --all -o MODEL.npz'",
            output, DEFAULT_WARN_CM, output,
        )  # fmt: skip
    if step == resumed_at:
        log.warning("warning: %s: no training step was taken (the budget was spent before this run)", output)
    return model
