"""`elastyle view` (a local web viewer) and `elastyle render` (clips side by side to a GIF or MP4)."""

from __future__ import annotations

import argparse
import logging
import os
from pathlib import Path
from typing import Any

from elastyle.cli.options import add_units_flag
from elastyle.errors import ElastyleError, UsageError

log = logging.getLogger("elastyle")

DEFAULT_PORT = 8765


def add_view_commands(commands: Any) -> None:
    """Register the `view` and `render` subcommands on an argparse subparsers object."""
    view = commands.add_parser(
        "view",
        help="watch clips side by side in a local web viewer (127.0.0.1 only)",
        description="Serve a page on 127.0.0.1 that plays the clips side by side (or overlaid) in sync.",
    )
    view.add_argument("clips", nargs="+", help="BVH or .glb files, folders, globs or zip archives")
    view.add_argument(
        "--port",
        type=int,
        help=f"port on 127.0.0.1 (default {DEFAULT_PORT}, or a free one if taken; 0 = any)",
    )
    view.add_argument("--no-browser", action="store_true", help="only serve and print the URL")
    view.add_argument(
        "--explain", help="JSON from `elastyle transfer --explain`: show each moment's style source"
    )
    add_units_flag(view, "each clip is drawn in centimetres from it")
    view.set_defaults(run=run_view)

    render = commands.add_parser(
        "render",
        help="render clips side by side to a GIF or MP4 (needs elastyle[render])",
        description="Draw the clips side by side, one panel each, into an animated GIF or an MP4 video.",
    )
    render.add_argument("clips", nargs="+", help="BVH or .glb files, folders, globs or zip archives")
    render.add_argument(
        "-o", "--output", required=True,
        help="output file: .gif or .mp4 (an MP4 is written as its frames are drawn, a GIF holds them all in memory: "
        "for long clips write .mp4; two clips of 106 s took 1.3 GB as GIF, 0.1 GB as MP4)",
    )  # fmt: skip
    render.add_argument("--fps", type=float, help="frame rate (default: the clips', at most 30 for GIF)")
    render.add_argument("--force", action="store_true", help="overwrite an existing output file")
    render.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_units_flag(render, "each clip is drawn in centimetres from it")
    render.set_defaults(run=run_render)


def _read_clips(specs: list[str], units: str | None) -> tuple[list[Any], list[str], list[str]]:
    """The clips the files, folders, globs or archives name (as `transfer` reads them), their labels, and
    their paths."""
    from elastyle.core.body import in_units
    from elastyle.io.dataset import find_clips
    from elastyle.viewer.app import distinct_labels

    clips = find_clips(specs)
    motions = [in_units(clip.read()[0], units) for clip in clips]
    # a file name given twice (the same take before and after, from two folders) labelled with its folders
    return motions, distinct_labels([clip.name for clip in clips]), [clip.name for clip in clips]


def run_render(args: argparse.Namespace) -> int:
    from elastyle.io.files import check_output_path
    from elastyle.viewer.render import render_clips

    check_output_path(args.output, force=args.force, inputs=tuple(args.clips))
    if args.fps is not None and not args.fps > 0:
        raise UsageError(f"--fps must be positive, got {args.fps}")
    motions, labels, _ = _read_clips(args.clips, args.units)
    num_frames = render_clips(
        motions, labels, args.output, fps=args.fps, force=args.force, progress=not args.no_progress
    )
    clips = f"{len(motions)} clip{'' if len(motions) == 1 else 's'}"
    log.info("wrote %s (%d frames, %s)", args.output, num_frames, clips)
    return 0


def _same_clip(recorded: str, working_folder: str | None, shown: str) -> bool:
    """Whether a path an explain file recorded is a clip shown: the same file (links followed) where the
    record says where its relative paths start, or the path is absolute; else (older files, which recorded
    paths relative to where transfer ran) the same file from here, or for the output the same name."""
    if working_folder is not None or os.path.isabs(recorded):
        start = working_folder or os.getcwd()
        return os.path.realpath(os.path.join(start, recorded)) == os.path.realpath(shown)
    return Path(recorded).name == Path(shown).name


def _shown_style_clips(explain: dict[str, Any], labels: list[str], paths: list[str]) -> None:
    """Each patch's style clip (in place) as the label of the clip shown that is the same file
    (`_same_clip`: an older record's style clip from here, not by name)."""
    working = explain["working_folder"] or os.getcwd()
    renamed = {}
    for label, recorded in explain["style_paths"].items():
        same = [shown for shown, path in zip(labels, paths) if _same_clip(recorded, working, path)]
        if same:
            renamed[label] = same[0]
    for track in explain["styles"] + explain["part_styles"]:
        for row in track["patches"]:
            row["style_clip"] = renamed.get(row["style_clip"], row["style_clip"])


def run_view(args: argparse.Namespace) -> int:
    import webbrowser

    from elastyle.viewer.app import build_payload, make_server, read_explain, server_url

    if args.port is not None and not 0 <= args.port <= 65535:
        raise UsageError(f"--port must lie between 0 and 65535, got {args.port}")
    explain = read_explain(args.explain) if args.explain else None
    motions, labels, paths = _read_clips(args.clips, args.units)
    written_for = explain["output_path"] if explain is not None else None
    if explain is not None and written_for:
        shown = [
            label
            for label, path in zip(labels, paths)
            if _same_clip(written_for, explain["working_folder"], path)
        ]
        if shown:
            explain["output"] = shown[0]  # the page finds the output by its label
        else:
            log.warning(
                "warning: %s was written for %s, which is not among the clips shown: its patches are drawn on "
                "their timeline all the same", args.explain, written_for,
            )  # fmt: skip
            # said on the page too, naming the file alone (no folder of the user's goes out)
            explain["warning"] = (
                f"written for {Path(written_for).name}, which is not among the clips shown: its patches are drawn "
                "on their timeline all the same"
            )
    if explain is not None:
        _shown_style_clips(explain, labels, paths)
    payload = build_payload(motions, labels, explain)
    if args.port is None:
        try:
            server = make_server(payload, DEFAULT_PORT)
        except ElastyleError:
            server = make_server(payload, 0)  # the usual port is taken: any free one will do
    else:
        server = make_server(payload, args.port)
    url = server_url(server)
    try:
        print(f"elastyle view: serving {len(motions)} clip(s) at {url} (Ctrl-C to stop)", flush=True)
        if not args.no_browser and not webbrowser.open(url):
            log.info("no browser found; open %s yourself", url)
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        server.server_close()
    return 0
