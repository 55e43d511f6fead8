"""`elastyle eval` (figures of one transfer, or the benchmark) and `elastyle demo` (the first run)."""

from __future__ import annotations

import argparse
import json
import logging
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

from elastyle.cli.options import add_units_flag
from elastyle.errors import ClipTooShortError, DatasetError, ElastyleError, SkeletonMismatchError, UsageError

if TYPE_CHECKING:
    from elastyle.core.motion import Motion
    from elastyle.model.file import StyleModel

log = logging.getLogger("elastyle")

DEMO_CONTENT = "dataset-2_walk_normal_005"
DEMO_STYLES = ("dataset-2_walk_exhausted_005", "dataset-2_walk_active_010", "dataset-2_walk_masculine_010")


def add_eval_commands(commands: Any) -> None:
    evaluate = commands.add_parser(
        "eval",
        help="figures of a transfer, or the benchmark over dataset pairs",
        description="Figures of one transfer (OUT --content C --style S: cadence and timing error, arm swing, "
        "foot skating, jitter, bone lengths, what the model can represent of the inputs), or the benchmark "
        "over the dataset's held-out pairs (--benchmark DATA).",
    )
    evaluate.add_argument("output", nargs="?", help="a transfer's output BVH")
    evaluate.add_argument("--content", action="append", help="the content clip of that transfer")
    evaluate.add_argument(
        "--style", action="append", help="the style clip of that transfer (one: its timing is compared)"
    )
    evaluate.add_argument(
        "--benchmark", metavar="DATA", help="run the benchmark on the dataset (zip or folder)"
    )
    evaluate.add_argument(
        "--pairs", type=_positive_int, default=24, help="benchmark pairs per set, at least 1 (default 24)"
    )
    evaluate.add_argument("--model", help="model file (default: the shipped model)")
    add_units_flag(evaluate, "the figures are reported in centimetres from it")
    evaluate.add_argument("--out", help="folder for benchmark.json and benchmark.md")
    evaluate.add_argument(
        "--json", action="store_true", help="print figures (or the --benchmark report) as JSON"
    )
    evaluate.add_argument(
        "--force", action="store_true", help="overwrite benchmark.json and benchmark.md in --out"
    )
    evaluate.set_defaults(run=run_eval)

    demo = commands.add_parser("demo", help="a neutral walk in three contrasting styles, with figures")
    demo.add_argument(
        "--data",
        help="the dataset zip or folder (default: $ELASTYLE_DATA, else ../shared/data/bandai-namco-2.zip)",
    )
    demo.add_argument(
        "-o", "--output", default="elastyle-demo", help="folder to write (default elastyle-demo)"
    )
    demo.add_argument("--no-render", action="store_true", help="skip the side-by-side GIF")
    demo.add_argument("--force", action="store_true", help="overwrite files in the folder")
    demo.set_defaults(run=run_demo)


def _positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def run_eval(args: argparse.Namespace) -> int:
    from elastyle.io.dataset import read_clip
    from elastyle.model.file import load_model

    if args.benchmark and args.units:
        raise UsageError(
            "--units applies to OUT, --content and --style; the benchmark's dataset is in centimetres"
        )
    if args.benchmark and args.output and not (args.content or args.style):
        raise UsageError(
            f"--benchmark takes one DATA, a folder or zip holding both the takes its classifiers train on and the "
            f"held-out takes (numbered % 5 == 0) it pairs, got {args.output} besides: put them in one folder"
        )
    if args.benchmark and (args.output or args.content or args.style):
        raise UsageError("give OUT.bvh --content C.bvh --style S.bvh, or --benchmark DATA, not both")
    if args.out and not args.benchmark:
        raise UsageError("--out is the benchmark's report folder; it needs --benchmark DATA")
    if args.benchmark:
        from elastyle.eval.suite import markdown_table, run_benchmark
        from elastyle.io.files import check_output_path, write_files_atomic

        folder = Path(args.out) if args.out else None
        if folder is not None and folder.exists():  # refused before the benchmark runs, not after
            if not folder.is_dir():
                raise UsageError(f"{folder}: --out must be a folder")
            for name in ("benchmark.json", "benchmark.md"):
                check_output_path(folder / name, force=args.force)
        model = load_model(args.model)
        report = run_benchmark(args.benchmark, model, args.pairs)
        table = markdown_table(report)
        print(json.dumps(_strict(report), indent=1) if args.json else table)
        if folder is not None:
            folder.mkdir(parents=True, exist_ok=True)
            write_files_atomic(
                [
                    (folder / "benchmark.json", json.dumps(_strict(report), indent=1).encode("utf-8"), ()),
                    (folder / "benchmark.md", table.encode("utf-8"), ()),
                ],
                force=args.force,
            )  # both or neither
        return 0
    if not (args.output and args.content and args.style):
        raise UsageError("give OUT.bvh --content C.bvh --style S.bvh, or --benchmark DATA")
    for flag, given in (("--content", args.content), ("--style", args.style)):
        if not all(given):
            raise UsageError(f"{flag} is empty; give the clip's path")
        if len(given) > 1:  # the last one used to be taken silently
            raise UsageError(
                f"{flag} is given {len(given)} times; eval compares the output with one content and one style "
                "clip (for a transfer from several style clips, give the one whose timing it should have)"
            )
    args.content, args.style = args.content[0], args.style[0]
    from elastyle.core.body import in_units, no_legs_note
    from elastyle.eval.report import transfer_figures
    from elastyle.model.depth import clip_depth

    model = load_model(args.model)
    paths = (args.output, args.content, args.style)
    clips = [in_units(read_clip(path)[0], args.units) for path in paths]
    for path, clip in zip(paths, clips):  # speeds, cadences and skating need frames to step between
        if clip.num_frames < 2:
            raise ClipTooShortError(f"{path}: {clip.num_frames} frame(s); eval needs at least 2")
    # clips the model reads (other names, joint order or axes, extra joints, a dropped root) on its joints,
    # so that every export of one rig gives the same figures and a transfer's inputs and output compare
    readable = [_read_by(model, clip, path) for clip, path in zip(clips, paths)]
    output, content, style = (
        _on_model_joints(model, clip) if reads else clip for clip, reads in zip(clips, readable)
    )
    # the figures compare the three clips joint by joint: one skeleton, as a transfer keeps it
    content.skeleton.check_same(output.skeleton, f"the content {args.content}", args.output)
    content.skeleton.check_same(style.skeleton, f"the content {args.content}", args.style)
    figures = transfer_figures(output, content, style)
    note = no_legs_note(output.skeleton, args.output)
    if note is not None:
        log.warning("%s", note)
    for name, motion, reads in ((args.content, content, readable[1]), (args.style, style, readable[2])):
        if reads:
            error, warning = clip_depth(model, motion, name)  # what the model can represent of the inputs
            figures[f"{'content' if motion is content else 'style'}_reconstruction_cm"] = error
            if warning is not None:
                log.warning("%s", warning)
        else:
            log.info(
                "note: %s: not the model's skeleton, so no reconstruction figure (--model names one)", name
            )
    _print_figures(figures, args.json)
    return 0


def _on_model_joints(model: StyleModel, motion: Motion) -> Motion:
    """A clip the model reads, on the model's joints under the model's names (a clip under other names,
    `mixamorig:Hips`, compares with one under the model's own)."""
    return model.on_model_hierarchy(motion).renamed(model.skeleton.names)


def _read_by(model: StyleModel, motion: Motion, path: str) -> bool:
    """Whether the model reads the clip (`StyleModel.check_clip`), its note logged where it is read
    otherwise than as the model's own skeleton."""
    try:
        note = model.check_clip(motion, path)
    except SkeletonMismatchError:
        return False
    if note is not None:
        log.info("%s", note)
    return True


def _strict(value: Any) -> Any:
    """A report with every NaN or infinite number as None (null in strict JSON)."""
    if isinstance(value, dict):
        return {key: _strict(item) for key, item in value.items()}
    if isinstance(value, list):
        return [_strict(item) for item in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _print_figures(figures: dict[str, float], as_json: bool) -> None:
    """The figures, one per line, or as JSON; a figure a clip does not define (no steady stepping gives no
    cadence) is n/a, or null in JSON."""
    defined = {key: (value if math.isfinite(value) else None) for key, value in figures.items()}
    if as_json:
        print(json.dumps(defined, indent=1))
        return
    width = max(map(len, figures), default=0) + 2
    for key, value in defined.items():
        print(f"  {key:<{width}}{'n/a' if value is None else f'{value:.3f}':>10}")


def run_demo(args: argparse.Namespace) -> int:
    from elastyle.eval.report import transfer_figures
    from elastyle.io.clip_write import clip_bytes
    from elastyle.io.dataset import (
        DATA_ENVIRONMENT_VARIABLE,
        PUBLIC_DATASET_HINT,
        default_data_path,
        find_clips,
    )
    from elastyle.io.files import write_files_atomic
    from elastyle.model.file import load_model
    from elastyle.pipeline import transfer
    from elastyle.steps.config import TransferConfig
    from elastyle.steps.library import prepare_style

    data = args.data or default_data_path()
    if data is None or not Path(data).exists():
        tried = data or (
            f"no --data, no ${DATA_ENVIRONMENT_VARIABLE}, and no ../shared/data/bandai-namco-2.zip beside the "
            f"project or the working folder {Path.cwd()}"
        )
        raise DatasetError(f"no dataset found ({tried}): {PUBLIC_DATASET_HINT}")
    clips = {c.stem: c for c in find_clips([str(data)], pattern="*_walk_*")}
    missing = [stem for stem in (DEMO_CONTENT, *DEMO_STYLES) if stem not in clips]
    if missing:
        raise DatasetError(
            f"{data}: demo clips missing ({', '.join(missing)}); is it the Bandai Namco dataset 2?"
        )
    folder = Path(args.output)
    if folder.exists():  # every output checked before the first is written
        from elastyle.io.files import check_output_path

        names = [f"{stem.split('_')[2]}_{method}{suffix}" for stem in DEMO_STYLES
                 for method in ("elastic", "rigid") for suffix in (".bvh", ".json")]  # fmt: skip
        for name in names + ([] if args.no_render else ["exhausted.gif"]):
            check_output_path(folder / name, force=args.force)
    folder.mkdir(parents=True, exist_ok=True)
    model = load_model()
    content, layout = clips[DEMO_CONTENT].read()
    print(f"content: {DEMO_CONTENT}  ->  {folder}/")
    rendered = [content]
    labels = [DEMO_CONTENT + " (content)"]
    for stem in DEMO_STYLES:
        style = clips[stem].read()[0]
        library = prepare_style(model, [style], [clips[stem].name])
        style_name = stem.split("_")[2]
        for method in ("elastic", "rigid"):
            result = transfer(content, library, TransferConfig(method=method), model=model)
            base = folder / f"{style_name}_{method}"
            output = base.with_suffix(".bvh")
            write_files_atomic(
                [
                    (output, clip_bytes(output, result.motion, layout), ()),
                    (base.with_suffix(".json"), json.dumps(result.explain, indent=1).encode("utf-8"), ()),
                ],
                force=args.force,
            )  # an output and its explain record: both or neither
            figures = transfer_figures(result.motion, content, style)
            print(
                f"  {style_name:<10} {method:<8} cadence {figures['cadence_content_steps_s']:.2f} -> "
                f"{figures['cadence_output_steps_s']:.2f} (style {figures['cadence_style_steps_s']:.2f}) steps/s, "
                f"timing error {figures['timing_error']:.2f}, skating {figures['skating_output_cm_s']:.1f} cm/s, "
                f"jitter x{figures['jitter_vs_content']:.2f}"
            )
            if method == "elastic" and style_name == "exhausted":
                rendered += [style, result.motion]
                labels += [stem + " (style)", f"{style_name} elastic"]
            if method == "rigid" and style_name == "exhausted":
                rendered.append(result.motion)
                labels.append(f"{style_name} rigid")
    if not args.no_render:
        try:
            from elastyle.viewer.render import render_clips

            render_clips(rendered, labels, folder / "exhausted.gif", force=args.force, progress=False)
            print(f"  side by side: {folder / 'exhausted.gif'}")
        except ElastyleError as error:  # rendering is an extra: the BVHs and figures stand without it
            log.info("no GIF: %s", error)
    return 0
