"""`elastyle transfer`: one content clip to one output file, or many content clips into a folder."""

from __future__ import annotations

import argparse
import logging
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

from elastyle.cli.batch import (
    Job,
    explain_path,
    names_folder,
    output_folder,
    require_dask,
    run_local,
    run_on_dask,
    transfer_one,
)
from elastyle.cli.options import add_config_flags, add_units_flag, config_from_args
from elastyle.core.body import guessed_unit_note
from elastyle.core.motion import Motion, leading_pose_note
from elastyle.errors import BvhError, OutputError, SkeletonMismatchError, UsageError
from elastyle.io.dataset import ClipRef, read_up
from elastyle.steps.config import TransferConfig

if TYPE_CHECKING:
    from elastyle.steps.library import StyleLibrary
    from elastyle.steps.schedule import Schedule

log = logging.getLogger("elastyle")


def add_transfer_command(commands: Any) -> None:
    parser = commands.add_parser(
        "transfer",
        help="perform content clips in the manner and timing of style clips",
        description="Perform CONTENT in the manner and timing of the --style clips (several form one library).",
    )
    parser.add_argument(
        "content",
        nargs="+",
        help="content BVH clip(s), or folders, globs and zip archives of them; several need -o FOLDER/",
    )
    parser.add_argument(
        "--style", action="append", required=True, help="style clip, folder, glob or zip path (repeatable)"
    )
    parser.add_argument(
        "-o",
        "--output",
        required=True,
        help="output file (.bvh, or .glb: binary glTF 2.0), or DIR/ for several content clips",
    )
    parser.add_argument(
        "--output-format", choices=("bvh", "glb"),
        help="with -o DIR/: the outputs' format, each named as its content clip with this extension "
        "(default: bvh); a file's format is its name's",
    )  # fmt: skip
    parser.add_argument("--model", help="model file (default: the shipped pretrained model)")
    add_units_flag(parser)
    add_config_flags(parser, TransferConfig)
    parser.add_argument(
        "--then-style", action="append", help="a second style to change to (see --at, --over)"
    )
    parser.add_argument("--at", type=float, help="content time (s) where the change to --then-style starts")
    parser.add_argument("--over", type=float, help="duration (s) of the change to --then-style (default 1)")
    parser.add_argument(
        "--style-part", action="append", metavar="PART=CLIP",
        help="body parts (legs, spine, left-arm, right-arm, arms; comma-separated) that take the manner of "
        "another style clip, folder or glob, on the --style clip's timing (repeatable)",
    )  # fmt: skip
    parser.add_argument("--blend-style", action="append", help="a second style blended in at --blend")
    parser.add_argument("--blend", type=float, help="share of --blend-style, 0..1 (default 0.5)")
    parser.add_argument(
        "--explain",
        help="write a JSON record of every output patch's source: a file for one content clip, or a folder (DIR/) "
        "for a record per output, named as the output with .json",
    )
    parser.add_argument("--no-cache", action="store_true", help="encode the style library afresh (no cache)")
    parser.add_argument(
        "--jobs", type=int, default=None, metavar="N",
        help="processes for several content clips (default: one per core)",
    )  # fmt: skip
    parser.add_argument(
        "--scheduler", metavar="ADDRESS",
        help="run several content clips on this Dask cluster (tcp://host:8786; elastyle[dask]); the workers "
        "read the content clips, so those must be on storage every worker sees; this command writes the outputs",
    )  # fmt: skip
    parser.add_argument(
        "--skip-existing",
        action="store_true",
        help="leave outputs that exist, or whose explain record does (resume a batch; for one content clip, its "
        "output)",
    )
    parser.add_argument("--force", action="store_true", help="overwrite existing output files")
    parser.set_defaults(run=run_transfer)


def _outputs(args: argparse.Namespace) -> tuple[list[str], list[Path], list[Path]]:
    """The content clips to transfer and their output files, and (with --skip-existing) the outputs left
    unwritten because only their explain record exists."""
    from elastyle.io.clip_write import check_output_format
    from elastyle.io.files import check_output_path, check_writable

    contents = args.content
    inputs = _inputs(args)
    if not args.output:
        raise UsageError("-o/--output is empty; give a file name (or DIR/ for several content clips)")
    output = Path(args.output)
    as_folder = names_folder(args.output)
    if as_folder and output.exists() and not output.is_dir():
        raise OutputError(f"{output}: a file, not a folder; give a folder for the outputs (-o DIR/)")
    if len(contents) == 1 and not as_folder:
        check_output_format(output)
        if args.output_format and output.suffix.lower() != f".{args.output_format}":
            raise UsageError(
                f"{output}: --output-format {args.output_format} names the format of outputs in a folder (-o DIR/);"
                f" a file's is its name's: name it {output.stem}.{args.output_format}"
            )
        if args.skip_existing and not args.force and _done(args, output):
            if output.exists():
                log.info("note: %s exists and is skipped (--skip-existing)", output)
            return [], [], [] if output.exists() else [output]
        return contents, [check_output_path(output, force=args.force, inputs=inputs)], []
    if not as_folder:
        raise UsageError(f"{args.output}: several content clips need an output folder: -o {args.output}/")
    if not output.is_dir() and not output.parent.is_dir():
        raise OutputError(
            f"{output}: several content clips need an output folder, and {output.parent} does not exist"
        )
    suffix = f".{args.output_format or 'bvh'}"
    targets = [output / (Path(c).stem + suffix) for c in contents]
    first: dict[Path, str] = {}
    for content, target in zip(contents, targets):
        if target in first:
            raise OutputError(f"{content} and {first[target]} would both be written to {target}; rename one")
        first[target] = content
    if not output.is_dir():  # made by `run_transfer` once everything is checked: nothing exists there yet
        check_writable(output)  # its parent takes the new folder
        return contents, targets, []
    unfinished: list[Path] = []
    if args.skip_existing and not args.force:
        kept = [(c, t) for c, t in zip(contents, targets) if not _done(args, t)]
        existing_outputs = sum(t.exists() for t in targets)
        unfinished = [t for t in targets if _done(args, t, quiet=True) and not t.exists()]
        if existing_outputs:
            log.info("note: %d of %d outputs exist and are skipped", existing_outputs, len(contents))
        contents, targets = [c for c, _ in kept], [t for _, t in kept]
    existing = [target for target in targets if target.is_file()]
    if existing and not args.force:  # in a batch, leaving what exists is the other way out
        raise OutputError(
            f"{existing[0]}: already exists (--force overwrites it; --skip-existing leaves the outputs that exist "
            "and writes the rest)"
        )
    return contents, [check_output_path(t, force=args.force, inputs=inputs) for t in targets], unfinished


def _done(args: argparse.Namespace, target: Path, quiet: bool = False) -> bool:
    """Whether --skip-existing leaves an output: it exists, or its explain record does (where --explain asks
    for one). Where only one of the two exists (a batch stopped between them, or one deleted) the clip is
    left too, with a warning naming the missing file: writing it would replace the other without --force."""
    record = explain_path(args.explain, target) if args.explain else None
    present = [path for path in (target, record) if path is not None and path.exists()]
    if record is not None and len(present) == 1 and not quiet:
        missing = record if present[0] == target else target
        log.warning(
            "warning: %s exists but %s does not: that clip is skipped (--force writes both anew)",
            present[0], missing,
        )  # fmt: skip
    return bool(present)


def _content_clips(specs: list[str], written: list[str]) -> list[str]:
    """The content arguments with folders, globs and zip archives (or folders inside them) replaced by the
    clips they hold; a clip's own path (a file, or a .bvh or .glb inside an archive) stays as it is. A clip
    named twice (through a link too) is read once; the clips a folder or glob finds directly in the folder
    the outputs are written to (`written`: -o DIR/), an earlier run's outputs, are not contents (a
    `UsageError` where they were all it found)."""
    from elastyle.io.dataset import CLIP_SUFFIXES, find_clips

    outputs = {os.path.normcase(os.path.realpath(folder)) for folder in written}
    clips: list[str] = []
    seen: set[str] = set()
    left = 0  # clips found in the outputs' folder
    for spec in specs:
        path = Path(spec)
        pattern = any(c in spec for c in "*?[")
        one = (path.is_file() and not spec.lower().endswith(".zip")) or (
            spec.lower().endswith(CLIP_SUFFIXES) and not pattern
        )
        for clip in [spec] if one else [clip.name for clip in find_clips([spec])]:
            key = os.path.normcase(os.path.realpath(clip))
            if key in seen:
                continue
            if not one and os.path.dirname(key) in outputs:
                left += 1
                continue
            seen.add(key)
            clips.append(clip)
    if left:
        said = f"{left} clip(s) in the folder the outputs are written to ({', '.join(written)})"
        if not clips:
            raise UsageError(
                f"{said} are all the content found: name the content clips, or another -o folder"
            )
        log.info("note: %s are an earlier run's outputs, not content", said)
    return clips


def _check_inputs_readable(specs: tuple[str, ...]) -> None:
    """Before any work: a `BvhError` for a named file that must not be read (a pipe, a device, too large)."""
    from elastyle.io.files import input_problem

    for spec in specs:
        path = Path(spec)
        if path.exists() and not path.is_dir():
            problem = input_problem(path)
            if problem is not None:
                raise BvhError(spec, problem)


def _inputs(args: argparse.Namespace) -> tuple[str, ...]:
    """Every file the command reads: no output may replace one of them, --force or not."""
    parts = [spec.partition("=")[2] for spec in args.style_part or []]
    styles = [*args.style, *(args.then_style or []), *(args.blend_style or []), *parts]
    return (*args.content, *styles, *([args.model] if args.model else []))


def run_transfer(args: argparse.Namespace) -> int:
    from elastyle.io.dataset import find_clips
    from elastyle.io.files import check_output_path
    from elastyle.model.file import load_model
    from elastyle.steps.cache import load_library
    from elastyle.steps.schedule import Schedule

    config = config_from_args(TransferConfig, args)  # validated once: a bad value is a UsageError
    _check_no_empty_paths(args)
    written = [args.output] if args.output and names_folder(args.output) else []  # the outputs' folder
    args.content = _content_clips(args.content, written)
    _check_style_options(args)
    if config.loop and (len(config.strength_schedule.values) > 1 or args.then_style):
        raise UsageError(
            "--loop takes a constant --strength and no --then-style: keyframes are times in one reading of the clip"
        )
    from elastyle.core.parts import parse_parts

    # --style-part checked before any work, and no part both kept and styled by another clip
    styled = {part for names, _ in _style_parts(args) for part in parse_parts(names, "--style-part")}
    both = sorted(styled & set(config.kept_parts))
    if both:
        raise UsageError(
            f"{', '.join(both)}: both kept (--keep-part) and given another clip (--style-part); give one"
        )
    contents, targets, unfinished = _outputs(args)
    if args.scheduler and len(args.content) > 1:
        require_dask()
    elif args.scheduler:
        log.info("note: --scheduler runs a batch of content clips; this one clip is transferred here")
    _check_inputs_readable(_inputs(args))
    for spec in args.content:  # a missing content file is named before any work on the style
        if not Path(spec).exists() and ".zip" not in spec.lower():
            find_clips([spec])
    if args.explain and names_folder(args.explain) and not Path(args.explain).is_dir():
        if not Path(args.explain).parent.is_dir():  # made with the first record
            raise OutputError(
                f"{args.explain}: the explain records' folder cannot be made: its parent does not exist"
            )
    elif args.explain:
        for target in targets:  # each record's file, as the outputs are checked before any work
            check_output_path(
                explain_path(args.explain, target),
                force=args.force,
                inputs=(*_inputs(args), *map(str, targets)),
            )
    model = load_model(args.model)

    def check(clip: ClipRef, motion: Motion) -> list[tuple[int, str]]:
        """How a style clip is read, as a content's is said: its notes (logging level, text)."""
        notes = []
        unit_note = guessed_unit_note(motion.skeleton, clip.name)  # a style in metres, as a content's is said
        for note in (model.check_clip(motion, clip.name), leading_pose_note(motion, clip.name), unit_note):
            if note is not None:  # kept with a cached library, and said again when it is read from there
                notes.append((logging.WARNING, note))
        if abs(motion.fps - model.fps) > 1e-6:
            resampled = (
                f"note: {clip.name} is {motion.fps:.6g} fps, resampled to the model's {model.fps:.6g} fps"
            )
            notes.append((logging.INFO, resampled))
        return notes

    def library(specs: list[str]) -> StyleLibrary:
        return load_library(
            model,
            find_clips(specs),
            config.mirror_style,
            use_cache=not args.no_cache,
            check=check,
            reverse_style=config.reverse_style,
            units=args.units,
        )

    try:
        style = library(args.style)
    except SkeletonMismatchError:
        if len(args.content) == 1:  # a content of another skeleton too is named first (read only here)
            from elastyle.io.dataset import read_clip

            model.check_clip(read_clip(args.content[0])[0], args.content[0])
        raise
    second = None
    second_weight: Schedule = Schedule.constant(0.0)
    if args.then_style:
        second = library(args.then_style)
        end = args.at + max(1.0 if args.over is None else args.over, 1e-3)
        second_weight = Schedule((args.at, end), (0.0, 1.0))
    elif args.blend_style:
        second = library(args.blend_style)
        second_weight = Schedule.constant(0.5 if args.blend is None else args.blend)

    part_styles = {names: library([spec]) for names, spec in _style_parts(args)}
    job = Job(
        style, model, config, second, second_weight, part_styles, args.units, read_up(), args.force,
        args.explain, _inputs(args), args.model, os.getcwd(),
    )  # fmt: skip
    status = _run_batch(args, job, contents, targets)
    if unfinished:  # said last, where a batch's summary would hide it
        log.error(
            "elastyle: error: %d output(s) not written, their explain records existing without them (%s%s): "
            "--force writes both anew",
            len(unfinished), unfinished[0], ", ..." if len(unfinished) > 1 else "",
        )  # fmt: skip
        return 1
    return status


def _run_batch(args: argparse.Namespace, job: Job, contents: list[str], targets: list[Path]) -> int:
    if not contents:  # every output exists and --skip-existing leaves them
        return 0
    if len(args.content) == 1:
        with output_folder(targets):
            transfer_one(job, contents[0], targets[0])
        return 0
    if args.scheduler:
        return run_on_dask(job, contents, targets, args.scheduler)
    return run_local(job, contents, targets, args.jobs)


def _style_parts(args: argparse.Namespace) -> list[tuple[str, str]]:
    """(part names, style spec) of each --style-part PART=CLIP; a UsageError for a malformed one."""
    from elastyle.core.parts import parse_parts

    pairs = []
    taken: set[str] = set()
    for spec in args.style_part or []:
        names, _, clip = spec.partition("=")
        if not names.strip() or not clip.strip():
            raise UsageError(f"--style-part {spec!r}: give PART=CLIP, for example arms=proud_walk.bvh")
        parts = parse_parts(names, "--style-part")  # a ConfigError (a usage error) for an unknown part
        twice = sorted(set(parts) & taken)
        if twice:
            raise UsageError(f"--style-part: {twice[0]} is given two styles; give each part one")
        taken |= set(parts)
        pairs.append((names, clip))
    return pairs


def _check_no_empty_paths(args: argparse.Namespace) -> None:
    """A UsageError naming the argument given an empty path (an unset shell variable, `--style "$S"`): read
    as the current folder, it named every clip under it."""
    named = {
        "the content": args.content,
        "--style": args.style,
        "--then-style": args.then_style or [],
        "--blend-style": args.blend_style or [],
        "--model": [] if args.model is None else [args.model],
        "--explain": [] if args.explain is None else [args.explain],
        "--scheduler": [] if args.scheduler is None else [args.scheduler],
    }
    for name, values in named.items():
        if any(not value.strip() for value in values):
            raise UsageError(f"{name}: an empty path or address (an unset shell variable?); give one")


def _check_style_options(args: argparse.Namespace) -> None:
    """Options that belong together: a UsageError (exit 2) for each combination that makes no sense."""
    if args.then_style and args.blend_style:
        raise UsageError("give --then-style or --blend-style, not both")
    if args.then_style and args.at is None:
        raise UsageError("--then-style needs --at SECONDS")
    if not args.then_style and (args.at is not None or args.over is not None):
        raise UsageError("--at and --over set the change to --then-style; give --then-style too")
    if not args.blend_style and args.blend is not None:
        raise UsageError("--blend sets the share of --blend-style; give --blend-style too")
    for name in ("at", "over", "blend"):
        value = getattr(args, name)
        if value is not None and not math.isfinite(value):
            raise UsageError(f"--{name} must be a finite number, got {value}")
    if args.over is not None and args.over <= 0:
        raise UsageError(f"--over must be positive, got {args.over:g} s")
    if args.at is not None and args.at < 0:
        raise UsageError(f"--at is a time in the content, from 0 s; got {args.at:g} s")
    if args.blend is not None and not 0 <= args.blend <= 1:
        raise UsageError(f"--blend must lie between 0 and 1, got {args.blend:g}")
    if args.skip_existing and args.force:
        raise UsageError(
            "give --skip-existing (leave outputs that exist) or --force (overwrite them), not both"
        )
    if args.jobs is not None and args.jobs < 1:
        raise UsageError(f"--jobs must be at least 1, got {args.jobs}")
    if args.explain and len(args.content) > 1 and not names_folder(args.explain):
        raise UsageError(
            f"--explain {args.explain}: several content clips write one record each: give a folder (--explain "
            f"{Path(args.explain).with_suffix('')}/)"
        )
