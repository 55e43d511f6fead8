"""The `elastyle` command line: info | convert | train | calibrate | transfer | view | render | eval | demo.

Errors a user can fix print one line (`elastyle: error: ...`) and exit 1 (bad data) or 2 (bad usage);
`--verbose` adds the traceback.
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import sys
import threading
from collections.abc import Sequence
from contextlib import nullcontext
from typing import NoReturn

from elastyle.errors import ElastyleError, UsageError

log = logging.getLogger("elastyle")


def _command_info(args: argparse.Namespace) -> int:
    from elastyle.core.body import centimetres_per_unit, standing_height
    from elastyle.io.dataset import find_clips

    models = [path for path in args.clip if path.lower().endswith((".npz", ".ckpt"))]
    for path in models:
        _print_model_info(path)
    clips = [path for path in args.clip if path not in models]
    failed = 0
    found = find_clips(clips) if clips else []
    for clip in found:
        try:
            motion, layout = clip.read()
        except ElastyleError as error:  # said, and the other clips described (exit 1 at the end)
            print(f"elastyle: error: {error}", file=sys.stderr)
            failed += 1
            continue
        skeleton = motion.skeleton
        channel_counts = sorted({len(c) for c in layout.channels})
        print(f"{clip.name}")
        print(f"  joints:   {skeleton.num_joints} ({', '.join(skeleton.names)})")
        print(
            f"  channels: {sum(len(c) for c in layout.channels)} ({'/'.join(map(str, channel_counts))} per joint)"
        )
        print(f"  frames:   {motion.num_frames} at {motion.fps:.6g} fps ({motion.duration_s:.3f} s)")
        positions = motion.positions()
        extent = float(positions[0, :, 1].max() - positions[0, :, 1].min())
        height = standing_height(skeleton)
        print(
            f"  height:   {height:.2f} file units standing, from its bone lengths: about "
            f"{height * centimetres_per_unit(skeleton):.0f} cm, its unit "
            f"{'as its file states' if skeleton.unit_cm else 'guessed'} (the first frame spans {extent:.2f})"
        )
        print(f"  up:       +{layout.up.upper()}")
    if failed and len(found) > 1:
        print(f"elastyle: {failed} of {len(found)} clips could not be read", file=sys.stderr)
    return 1 if failed else 0


def _print_model_info(path: str) -> None:
    """A model file's shape, skeleton, training and held-out figures, as `info` prints them."""
    from elastyle.model.file import load_model

    model = load_model(path)
    config, metadata = model.autoencoder.config, model.metadata
    skeleton = model.skeleton
    print(path)
    print(
        f"  model:    latent {config.latent_channels}, hidden {config.hidden_channels}, kernel "
        f"{config.kernel_frames} frames, {'tied' if config.tied else 'untied'} decoder, at {model.fps:g} fps"
    )
    print(f"  joints:   {skeleton.num_joints} ({', '.join(skeleton.names)})")
    if "steps" in metadata:
        print(
            f"  trained:  {metadata['steps']} steps in {metadata.get('training_minutes', 0):g} min on "
            f"{metadata.get('training_clips', '?')} clip{'' if metadata.get('training_clips') == 1 else 's'}, "
            f"{metadata.get('held_out_clips', '?')} held out"
        )
    if metadata.get("data"):  # models trained since these were recorded
        excluded = f" less {', '.join(metadata['excluded'])}" if metadata.get("excluded") else ""
        print(
            f"  data:     {', '.join(metadata['data'])}{excluded}; {metadata.get('trained_utc', '?')} UTC, "
            f"elastyle {metadata.get('elastyle_version', '?')}"
        )
    recipe = metadata.get("train_config")
    if isinstance(recipe, dict):
        window_s = recipe.get("window_s")
        if isinstance(metadata.get("window_frames"), int):  # as trained (shorter where the clips were)
            window_s = metadata["window_frames"] / model.fps
        augment = ", ".join(
            f"{name} {recipe[key]:g}"
            for name, key in (("reverse", "reverse_augment"), ("speed", "speed_augment"),
                              ("perturb", "perturb_augment"), ("position loss", "position_loss"))
            if recipe.get(key)
        )  # fmt: skip
        print(
            f"  recipe:   batch {recipe.get('batch_size')}, learning rate {recipe.get('learning_rate'):g} "
            f"{recipe.get('lr_schedule', 'constant')}, windows {window_s:.3g} s"
            f"{', mirrored' if recipe.get('mirror_augment') else ''}{', ' + augment if augment else ''}"
        )
    error = metadata.get("held_out_joint_error_cm")
    if isinstance(error, dict):
        print(
            f"  held out: joint error median {error['median']:g} cm, 95th percentile {error['p95']:g} cm; "
            f"out-of-depth warning above {metadata.get('reconstruction_warn_cm', 0):g} cm"
        )


def _command_convert(args: argparse.Namespace) -> int:
    from elastyle.core.body import in_units
    from elastyle.core.mirror import mirror, unpaired_note
    from elastyle.errors import SkeletonMismatchError
    from elastyle.io.bvh_read import MAX_FRAME_TIME_S, MIN_FRAME_TIME_S
    from elastyle.io.clip_write import check_output_format, write_clip
    from elastyle.io.dataset import read_clip
    from elastyle.io.files import check_output_path

    if args.fps is not None and not 1 / MAX_FRAME_TIME_S <= args.fps <= 1 / MIN_FRAME_TIME_S:
        raise UsageError(
            f"--fps must lie between {1 / MAX_FRAME_TIME_S:g} and {1 / MIN_FRAME_TIME_S:g}, got {args.fps:g}"
        )
    check_output_format(args.output)
    check_output_path(args.output, force=args.force, inputs=(args.input,))
    motion, layout = read_clip(args.input)
    motion = in_units(motion, args.units)
    if args.fps is not None:
        motion = motion.resample(args.fps)
        layout = layout._replace(frame_time_s=1.0 / args.fps)
    if args.mirror:
        try:
            motion = mirror(motion)
        except SkeletonMismatchError as error:
            raise SkeletonMismatchError(f"{args.input}: {error}") from None
        note = unpaired_note(motion.skeleton, args.input)
        if note is not None:
            log.warning("%s", note)
    write_clip(args.output, motion, layout, force=args.force, inputs=(args.input,))
    log.info("wrote %s (%d frames at %.6g fps)", args.output, motion.num_frames, motion.fps)
    return 0


class _OneLineParser(argparse.ArgumentParser):
    """Usage errors as one line, as every other error is (argparse prints the whole usage first)."""

    commands: dict[str, argparse.ArgumentParser]  # the top-level parser's: each command's own parser

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


VERBOSE_HELP = "show tracebacks and debug logging"
UP_HELP = (
    "the BVH files' up axis: auto (default: +Z for a clip whose body clearly stands along +Z, else +Y), y "
    "or z; clips are worked on with +Y up and written back standing as their files do"
)


def build_parser() -> _OneLineParser:
    from elastyle.cli.options import add_units_flag
    from elastyle.io.dataset import READ_UPS

    parser = _OneLineParser(prog="elastyle", description="Zero-shot motion style transfer for BVH clips.")
    parser.add_argument("--verbose", action="store_true", help=VERBOSE_HELP)
    parser.add_argument("--up", choices=READ_UPS, default="auto", help=UP_HELP)
    commands = parser.add_subparsers(dest="command", required=True)

    info = commands.add_parser(
        "info",
        help="joints, channels, frames, fps, duration and height of clips; a model file's shape and training",
    )
    info.add_argument(
        "clip",
        nargs="+",
        help="BVH or .glb files, folders, globs or zip archives of them, or model files (.npz)",
    )
    info.set_defaults(run=_command_info)

    convert = commands.add_parser(
        "convert",
        help="resample, mirror and rewrite a clip, as BVH or .glb",
        description="Rewrite one clip (BVH or .glb, also inside a zip) as BVH or binary glTF (.glb, metres and "
        "+Y up): resampled to another frame rate, mirrored left to right, or just converted.",
    )
    convert.add_argument("input")
    convert.add_argument("-o", "--output", required=True, help="output file: .bvh or .glb (binary glTF 2.0)")
    convert.add_argument("--fps", type=float, help="resample to this frame rate")
    convert.add_argument("--mirror", action="store_true", help="swap left and right")
    convert.add_argument("--force", action="store_true", help="overwrite an existing output file")
    add_units_flag(convert, "a .glb output is scaled to metres from it")
    convert.set_defaults(run=_command_convert)

    from elastyle.cli.train import add_train_commands

    add_train_commands(commands)

    from elastyle.cli.transfer import add_transfer_command

    add_transfer_command(commands)

    from elastyle.cli.view import add_view_commands

    add_view_commands(commands)

    from elastyle.cli.eval import add_eval_commands

    add_eval_commands(commands)
    for command in commands.choices.values():  # also after the command's name (the default: before it)
        command.add_argument("--verbose", action="store_true", default=argparse.SUPPRESS, help=VERBOSE_HELP)
        command.add_argument("--up", choices=READ_UPS, default=argparse.SUPPRESS, help=UP_HELP)
    parser.commands = dict(commands.choices)
    return parser


def _interrupted(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def main(argv: Sequence[str] | None = None) -> int:
    try:
        return _main(argv)
    except KeyboardInterrupt:  # while the command's modules load (a command's own run answers it itself)
        print("elastyle: interrupted", file=sys.stderr)
        return 130


def _main(argv: Sequence[str] | None) -> int:
    from threadpoolctl import threadpool_limits

    parser = build_parser()
    args, unknown = parser.parse_known_args(argv)
    if unknown:  # named by the command's own parser, so the error points to its --help
        hint = ""
        if getattr(args, "command", None) == "transfer" and not any(u.startswith("-") for u in unknown):
            # clips after a --style that takes one: the usual slip with several style clips
            hint = f"; give each style clip its own --style (--style {unknown[0]}), or a folder or glob"
        parser.commands[args.command].error(f"unrecognized arguments: {' '.join(unknown)}{hint}")
    # elastyle's own messages from INFO on (DEBUG with --verbose); other libraries' from WARNING on: torch,
    # interrupted while it loads, had its INFO log (FakeTensor cache statistics) printed at exit
    logging.basicConfig(level=logging.WARNING, format="%(message)s", stream=sys.stderr)
    logging.getLogger("elastyle").setLevel(logging.DEBUG if args.verbose else logging.INFO)
    from elastyle.io.dataset import set_read_up

    set_read_up(args.up)
    # one BLAS thread, as every transfer runs (`core.threads`): the same numbers whatever the machine, and on
    # the small products here the fast way (a pooled library's 64 x 64 eigendecomposition took 28 to 56 ms
    # on two threads of a loaded 2-core machine, 0.5 on one); training sets its own threads (--threads)
    limit = nullcontext() if args.command == "train" else threadpool_limits(limits=1, user_api="blas")
    # a kill ends a command as Ctrl-C does (training handles both itself: it stops with a checkpoint)
    previous = None
    if args.command != "train" and threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, _interrupted)
    try:
        with limit:
            return int(args.run(args) or 0)
    except ElastyleError as error:
        if args.verbose:
            raise
        print(f"elastyle: error: {error}", file=sys.stderr)
        return 2 if isinstance(error, UsageError) else 1
    except KeyboardInterrupt:
        print("elastyle: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader of our output stopped reading (`| head`): nothing more to say
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
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
    finally:
        if previous is not None:  # the caller's own handler back (main() may run inside a program)
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":
    sys.exit(main())
