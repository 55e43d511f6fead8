"""The `elastyle` command line: info | convert | train | transfer.

Errors a user can fix print one line (`elastyle: error: ...`) and exit 1 (bad data) or 2 (bad usage);
`--verbose` adds the traceback.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence

from elastyle.errors import ElastyleError, OutputError, UsageError

log = logging.getLogger("elastyle")


def _command_info(args: argparse.Namespace) -> int:
    from elastyle.io.dataset import find_clips

    for clip in find_clips([args.clip]):
        motion, layout = clip.read()
        skeleton = motion.skeleton
        channel_counts = sorted({len(c) for c in layout.channels})
        print(f"{clip.name}")
        print(f"  joints:   {skeleton.num_joints} ({', '.join(skeleton.names)})")
        print(
            f"  channels: {sum(len(c) for c in layout.channels)} ({'/'.join(map(str, channel_counts))} per joint)"
        )
        print(f"  frames:   {motion.num_frames} at {motion.fps:.6g} fps ({motion.duration_s:.3f} s)")
        positions = motion.positions()
        print(
            f"  height:   {float(positions[0, :, 1].max() - positions[0, :, 1].min()):.2f} file units (first frame)"
        )
    return 0


def _command_convert(args: argparse.Namespace) -> int:
    from elastyle.core.mirror import mirror
    from elastyle.io.bvh_write import write_bvh
    from elastyle.io.dataset import read_clip
    from elastyle.io.files import check_output_path

    check_output_path(args.output, force=args.force, inputs=(args.input,))
    motion, layout = read_clip(args.input)
    if args.fps is not None:
        if args.fps <= 0:
            raise OutputError(f"--fps must be positive, got {args.fps}")
        motion = motion.resample(args.fps)
        layout = type(layout)(layout.channels, 1.0 / args.fps)
    if args.mirror:
        motion = mirror(motion)
    write_bvh(args.output, motion, layout, force=args.force)
    log.info("wrote %s (%d frames at %.6g fps)", args.output, motion.num_frames, motion.fps)
    return 0


def _command_train(args: argparse.Namespace) -> int:
    from elastyle.io.files import check_output_path
    from elastyle.model.config import ModelConfig

    check_output_path(args.output, force=args.force)
    try:
        import torch
    except ImportError:
        raise ElastyleError("training needs torch: pip install 'elastyle[train]'") from None
    from elastyle.training.config import TrainConfig
    from elastyle.training.loop import train

    if args.threads:
        torch.set_num_threads(args.threads)
    if args.minutes is None and args.steps is None:
        raise UsageError("give a training budget: --minutes or --steps")
    model_config = ModelConfig(
        hidden_channels=args.hidden,
        latent_channels=args.latent,
        kernel_frames=args.kernel,
        tied=not args.untied,
    )
    config = TrainConfig(
        model=model_config,
        batch_size=args.batch_size,
        learning_rate=args.lr,
        lr_schedule=args.lr_schedule,
        window_s=args.window_s,
        minutes=args.minutes,
        steps=args.steps,
        seed=args.seed,
        mirror_augment=not args.no_mirror,
        reverse_augment=args.reverse_augment,
        speed_augment=args.speed_augment,
        fps=args.fps,
        position_loss=args.position_loss,
    )
    train(
        args.data, args.output, config, resume=args.resume, force=args.force, progress=not args.no_progress,
        exclude=args.exclude or (),
    )  # fmt: skip
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="elastyle", description="Zero-shot motion style transfer for BVH clips."
    )
    parser.add_argument("--verbose", action="store_true", help="show tracebacks and debug logging")
    commands = parser.add_subparsers(dest="command", required=True)

    info = commands.add_parser("info", help="joints, channels, frames, fps, duration and height of a clip")
    info.add_argument("clip", help="a BVH file (or a path inside a zip archive)")
    info.set_defaults(run=_command_info)

    convert = commands.add_parser("convert", help="resample, mirror and rewrite a BVH clip")
    convert.add_argument("input")
    convert.add_argument("-o", "--output", required=True)
    convert.add_argument("--fps", type=float, help="resample to this frame rate")
    convert.add_argument("--mirror", action="store_true", help="swap left and right")
    convert.add_argument("--force", action="store_true", help="overwrite an existing output file")
    convert.set_defaults(run=_command_convert)

    trainer = commands.add_parser("train", help="train an autoencoder on BVH clips (needs elastyle[train])")
    trainer.add_argument("data", nargs="+", help="BVH files, folders, globs or zip archives")
    trainer.add_argument("-o", "--output", required=True, help="model file to write (.npz)")
    trainer.add_argument("--minutes", type=float, help="time budget")
    trainer.add_argument("--steps", type=int, help="step budget")
    trainer.add_argument("--seed", type=int, default=0)
    trainer.add_argument(
        "--resume", help="checkpoint to continue from (MODEL.ckpt is written as training goes)"
    )
    trainer.add_argument("--batch-size", type=int, default=16)
    trainer.add_argument("--lr", type=float, default=1e-4, help="Adam learning rate (report: 1e-4)")
    trainer.add_argument("--lr-schedule", choices=("constant", "cosine"), default="constant")
    trainer.add_argument("--window-s", type=float, default=4.0, help="training window length, seconds")
    trainer.add_argument("--hidden", type=int, default=256)
    trainer.add_argument("--latent", type=int, default=32)
    trainer.add_argument("--kernel", type=int, default=15)
    trainer.add_argument("--untied", action="store_true", help="decoder with weights of its own")
    trainer.add_argument("--no-mirror", action="store_true", help="no mirrored clips as augmentation")
    trainer.add_argument(
        "--reverse-augment", type=float, default=0.0, help="share of training windows played backwards"
    )
    trainer.add_argument(
        "--speed-augment", type=float, default=0.0,
        help="share of batches played at a speed drawn from 0.5x to 2x",
    )  # fmt: skip
    trainer.add_argument(
        "--exclude", action="append", help="leave out clips whose name matches this glob (repeatable)"
    )
    trainer.add_argument("--fps", type=float, help="resample clips to this rate (default: the first clip's)")
    trainer.add_argument(
        "--position-loss",
        type=float,
        default=0.0,
        help="weight of a forward-kinematics joint position and velocity loss (0 = the report's)",
    )
    trainer.add_argument("--threads", type=int, help="torch CPU threads")
    trainer.add_argument("--no-progress", action="store_true")
    trainer.add_argument("--force", action="store_true", help="overwrite an existing model file")
    trainer.set_defaults(run=_command_train)

    from elastyle.cli.transfer import add_transfer_command

    add_transfer_command(commands)

    from elastyle.cli.view import add_view_commands

    add_view_commands(commands)

    from elastyle.cli.eval import add_eval_commands

    add_eval_commands(commands)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.INFO, format="%(message)s", stream=sys.stderr
    )
    try:
        return int(args.run(args) or 0)
    except ElastyleError as error:
        if args.verbose:
            raise
        print(f"elastyle: error: {error}", file=sys.stderr)
        return 2 if isinstance(error, UsageError) else 1
    except KeyboardInterrupt:
        print("elastyle: interrupted", file=sys.stderr)
        return 130
    except OSError as error:
        if args.verbose:
            raise
        print(f"elastyle: error: {error}", file=sys.stderr)
        return 1
    except MemoryError:
        if args.verbose:
            raise
        print(
            "elastyle: error: out of memory (try a shorter clip or a smaller style library)", file=sys.stderr
        )
        return 1
    except Exception as error:  # a bug, not bad input: still one line unless --verbose
        if args.verbose:
            raise
        print(
            f"elastyle: internal error: {type(error).__name__}: {error} (rerun with --verbose and report it)",
            file=sys.stderr,
        )
        return 1


if __name__ == "__main__":
    sys.exit(main())
