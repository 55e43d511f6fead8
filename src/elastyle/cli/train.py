"""`elastyle train` (a model for any skeleton) and `elastyle calibrate` (its held-out figures)."""

from __future__ import annotations

import argparse
import logging
import math
from typing import Any

from elastyle.errors import ElastyleError, OutputError, UsageError

log = logging.getLogger("elastyle")


def add_train_commands(commands: Any) -> None:
    trainer = commands.add_parser(
        "train",
        help="train an autoencoder on BVH clips (needs elastyle[train])",
        description="Train a model for your own skeleton on its BVH clips (every clip one skeleton; other "
        "units and body sizes are brought to the first clip's). Takes numbered % 5 == 0 (the number that ends "
        "the file name; without one, one name in five by its checksum) are held out to measure the model and set its "
        "out-of-depth warning. MODEL.npz.ckpt is written as training goes; --resume continues it.",
    )
    trainer.add_argument("data", nargs="+", help="BVH files, folders, globs or zip archives")
    trainer.add_argument("-o", "--output", required=True, help="model file to write (.npz)")
    trainer.add_argument(
        "--minutes",
        type=float,
        help="time budget of the whole training (with --resume, the time already spent counts)",
    )
    trainer.add_argument(
        "--steps",
        type=int,
        help="step budget of the whole training (with --resume, the steps already taken count)",
    )
    trainer.add_argument("--seed", type=int, help="random seed (default 0)")
    trainer.add_argument(
        "--resume",
        help="checkpoint to continue from (MODEL.npz.ckpt is written as training goes; with --force once the "
        "model file exists): training goes on up to --minutes or --steps in all, so give a larger budget than the "
        "first run's",
    )
    trainer.add_argument(
        "--recipe", choices=("report", "shipped"),
        help="the flags below as the report sets them, or as the shipped model was trained (MODEL_CARD.md: "
        "latent 64, untied, and the augmentations); flags given override it (default report; with --resume, "
        "the settings the checkpoint was trained with)",
    )  # fmt: skip
    trainer.add_argument("--batch-size", type=int, help="windows per step (default 16; shipped: 32)")
    trainer.add_argument(
        "--lr", type=float, help="Adam learning rate (default 1e-4, the report's; shipped: 1e-3)"
    )
    trainer.add_argument(
        "--lr-schedule", choices=("constant", "cosine"),
        help="constant, or cosine decay over the budget (default constant; shipped: cosine)",
    )  # fmt: skip
    trainer.add_argument(
        "--window-s", type=float, help="training window length, seconds (default 4; shipped: 2)"
    )
    trainer.add_argument("--hidden", type=int, help="hidden channels (default 256)")
    trainer.add_argument(
        "--latent", type=int, help="latent channels, the search's width (default 32, the report's; shipped: 64)",
    )  # fmt: skip
    trainer.add_argument("--kernel", type=int, help="convolution width, frames (default 15)")
    trainer.add_argument(
        "--untied", action="store_const", const=True,
        help="decoder with weights of its own (default: tied, the report's; shipped: untied)",
    )  # fmt: skip
    trainer.add_argument("--no-mirror", action="store_true", help="no mirrored clips as augmentation")
    trainer.add_argument(
        "--reverse-augment",
        type=float,
        help="share of training windows played backwards (default 0; shipped: 0.3)",
    )
    trainer.add_argument(
        "--speed-augment", type=float,
        help="share of batches played at a speed drawn from 0.5x to 2x (default 0; shipped: 0.5)",
    )  # fmt: skip
    trainer.add_argument(
        "--perturb-augment", type=float,
        help="share of training windows whose joints get random offsets within their recorded ranges "
        "(default 0; shipped: 1)",
    )  # fmt: skip
    trainer.add_argument(
        "--perturb-scale", type=float,
        help="size of those offsets, in standard deviations of each channel (default 0.5; shipped: 1)",
    )  # fmt: skip
    trainer.add_argument(
        "--exclude",
        action="append",
        help="leave out clips whose file name (with or without its extension) or path matches this glob (repeatable)",
    )
    trainer.add_argument("--fps", type=float, help="resample clips to this rate (default: the first clip's)")
    trainer.add_argument(
        "--position-loss",
        type=float,
        help="weight of a forward-kinematics joint position and velocity loss (default 0, the report's; "
        "shipped: 1)",
    )
    trainer.add_argument("--threads", type=int, help="torch CPU threads")
    trainer.add_argument("--no-progress", action="store_true", help="no progress bar")
    trainer.add_argument("--force", action="store_true", help="overwrite an existing model file")
    trainer.set_defaults(run=_command_train)

    calibrate = commands.add_parser(
        "calibrate",
        help="record a model's held-out reconstruction error, which sets its out-of-depth warning",
        description="Measure how well a model reproduces its held-out takes (mean joint error, cm) and write "
        "the model with those figures: transfer and eval warn when a content clip reproduces worse than twice "
        "their 95th percentile (and at least 1 cm). `elastyle train` does this at its end.",
    )
    calibrate.add_argument("model", help="model file (.npz)")
    calibrate.add_argument("data", nargs="+", help="its clips: the held-out takes among them are measured")
    calibrate.add_argument(
        "--all", action="store_true", help="measure every clip given (clips the model was not trained on)"
    )
    calibrate.add_argument("-o", "--output", required=True, help="model file to write")
    calibrate.add_argument("--force", action="store_true", help="overwrite an existing model file")
    calibrate.set_defaults(run=_command_calibrate)


def _check_train_args(args: argparse.Namespace) -> None:
    """Every option's value, before any clip is read: a `UsageError` (exit 2) naming the flag."""
    if args.minutes is None and args.steps is None:
        raise UsageError("give a training budget: --minutes or --steps")
    positive = {"minutes": args.minutes, "lr": args.lr, "window_s": args.window_s, "fps": args.fps}
    for name, value in positive.items():
        if value is not None and not (math.isfinite(value) and value > 0):
            raise UsageError(f"--{name.replace('_', '-')} must be a positive number, got {value:g}")
    counts = {"steps": args.steps, "batch_size": args.batch_size, "hidden": args.hidden,
              "latent": args.latent, "kernel": args.kernel, "threads": args.threads}  # fmt: skip
    for name, count in counts.items():
        if count is not None and count < 1:
            raise UsageError(f"--{name.replace('_', '-')} must be at least 1, got {count}")
    if args.kernel is not None and args.kernel % 2 == 0:
        raise UsageError(
            f"--kernel must be odd (the convolution is centred on each frame), got {args.kernel}"
        )
    for flag in ("reverse_augment", "speed_augment", "perturb_augment"):
        if getattr(args, flag) is not None and not 0 <= getattr(args, flag) <= 1:
            raise UsageError(f"--{flag.replace('_', '-')} is a share of windows, from 0 to 1")
    if args.perturb_scale is not None and not 0 <= args.perturb_scale <= 10:
        raise UsageError("--perturb-scale is in standard deviations, from 0 to 10")
    if args.position_loss is not None and not (math.isfinite(args.position_loss) and args.position_loss >= 0):
        raise UsageError(f"--position-loss must be 0 or more, got {args.position_loss:g}")


def _check_train_outputs(args: argparse.Namespace) -> None:
    """The model file and its checkpoint, before any work: a `.npz` that replaces none of the inputs, in a
    folder this process can write to, and no earlier training's checkpoint lost without --force."""
    from pathlib import Path

    from elastyle.io.files import check_output_path

    target = Path(args.output)
    if target.suffix.lower() != ".npz":
        raise UsageError(f"{args.output}: a model file is written as .npz; give -o MODEL.npz")
    inputs = (*args.data, *([args.resume] if args.resume else []))
    check_output_path(target, force=args.force, inputs=inputs)
    if args.resume is not None and not Path(args.resume).is_file():
        raise ElastyleError(f"{args.resume}: no such checkpoint (MODEL.npz.ckpt, written as training goes)")
    checkpoint = Path(str(target) + ".ckpt")
    resuming_it = args.resume is not None and Path(args.resume).resolve() == checkpoint.resolve()
    if checkpoint.exists() and not args.force and not resuming_it:
        raise OutputError(
            f"{checkpoint}: an earlier training's checkpoint; continue it with --resume {checkpoint}, or "
            "start over with --force"
        )


def _command_train(args: argparse.Namespace) -> int:
    _check_train_args(args)
    _check_train_outputs(args)
    from elastyle.training.checkpoint import checkpoint_config, interrupts_deferred

    try:
        with interrupts_deferred():  # torch's import cut short by Ctrl-C left the command killed or aborting
            import torch
    except ImportError:
        raise ElastyleError("training needs torch: pip install 'elastyle[train]'") from None
    from elastyle.training.loop import train

    if args.threads:
        from elastyle.core.threads import usable_cores

        cores = usable_cores()
        if args.threads > cores:
            log.warning(
                "warning: --threads %d on %d core(s): threads beyond the cores wait on each other and slow "
                "training (64 threads on 2 cores took 4.7 times as long as 1)", args.threads, cores,
            )  # fmt: skip
        torch.set_num_threads(args.threads)
    config = train_config(args, checkpoint_config(args.resume) if args.resume else None)
    train(
        args.data, args.output, config, resume=args.resume, force=args.force, progress=not args.no_progress,
        exclude=args.exclude or (),
    )  # fmt: skip
    return 0


def train_config(args: argparse.Namespace, resumed: Any = None) -> Any:
    """The `TrainConfig` of the parsed flags: where a flag is not given, the `--recipe`'s value, else the
    resumed checkpoint's (`resumed`, its `TrainConfig`), else the report's recipe's. The budget is the
    flags' own."""
    from dataclasses import replace

    from elastyle.training.config import RECIPES

    def given(**values: Any) -> dict[str, Any]:
        return {name: value for name, value in values.items() if value is not None}

    recipe = RECIPES[args.recipe] if args.recipe else resumed or RECIPES["report"]
    model = replace(
        recipe.model,
        **given(hidden_channels=args.hidden, latent_channels=args.latent, kernel_frames=args.kernel,
                tied=None if args.untied is None else False),
    )  # fmt: skip
    return replace(
        recipe, model=model, minutes=args.minutes, steps=args.steps,
        **given(seed=args.seed, mirror_augment=False if args.no_mirror else None, fps=args.fps),
        **given(batch_size=args.batch_size, learning_rate=args.lr, lr_schedule=args.lr_schedule,
                window_s=args.window_s, reverse_augment=args.reverse_augment, speed_augment=args.speed_augment,
                perturb_augment=args.perturb_augment, perturb_scale=args.perturb_scale,
                position_loss=args.position_loss),
    )  # fmt: skip


def _command_calibrate(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from elastyle.io.dataset import find_clips, is_held_out
    from elastyle.io.files import check_output_path
    from elastyle.model.depth import calibrate
    from elastyle.model.file import load_model, save_model

    check_output_path(args.output, force=args.force, inputs=(args.model,))
    model = load_model(args.model)
    held_out = [clip for clip in find_clips(args.data) if args.all or is_held_out(clip)]
    if not held_out:
        raise ElastyleError(
            f"{', '.join(args.data)}: no held-out takes to measure (takes numbered % 5 == 0 by the number "
            "ending the file name; --all measures every clip given)"
        )
    chosen = held_out[:: max(1, len(held_out) // 300)]
    motions = [clip.read()[0] for clip in chosen]
    for clip, motion in zip(chosen, motions):
        model.check_clip(motion, clip.name)
    figures = calibrate(model, motions)
    save_model(args.output, replace(model, metadata={**model.metadata, **figures}), force=args.force)
    error = figures["held_out_joint_error_cm"]
    log.info("wrote %s: held-out joint error median %.2f cm, 95th percentile %.2f cm, warning above %.2f cm",
             args.output, error["median"], error["p95"], figures["reconstruction_warn_cm"])  # fmt: skip
    return 0
