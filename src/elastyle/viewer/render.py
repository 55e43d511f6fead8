"""Render clips side by side to an animated GIF or MP4 (the optional extra `elastyle[render]`).

Each panel draws one clip's skeleton in a fixed oblique orthographic projection (+Y up), a ground grid and
the pelvis path on the ground; the view follows the pelvis horizontally so a long walk stays in frame.
matplotlib (Agg canvas, no window), Pillow and, for MP4, imageio-ffmpeg are imported only when called.
"""

from __future__ import annotations

import io
import logging
import math
import os
import tempfile
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from elastyle.core.body import centimetres_per_unit, find_limbs
from elastyle.core.motion import Motion
from elastyle.core.parts import subtree
from elastyle.core.resample import interpolate_rows
from elastyle.core.skeleton import Skeleton
from elastyle.errors import ElastyleError, OutputError, UsageError
from elastyle.io.files import check_output_path, write_bytes_atomic
from elastyle.types import FloatArray, IntArray

log = logging.getLogger("elastyle")

INSTALL_HINT = "pip install 'elastyle[render]'"
PANEL_PX = (256, 320)  # width, height of one panel; multiples of 16 for the MP4 encoder
MAX_GIF_FPS = 50.0  # GIF delays count in 10 ms; players slow down anything below 20 ms
_AZIMUTH_RAD = math.radians(35.0)  # camera swung from +Z (the front) towards +X
_ELEVATION_RAD = math.radians(18.0)  # camera above the ground plane, looking down
SIDE_COLOURS = ("#333333", "#1f6fd1", "#d1431f")  # centre, left, right
GRID_COLOUR = "#d5d5d5"
PATH_COLOUR = "#2a9d55"


def bones(skeleton: Skeleton) -> IntArray:
    """(B, 2) parent, child joint pairs to draw: every bone below the pelvis (not root -> pelvis)."""
    pelvis = skeleton.pelvis
    pairs = [(int(p), j) for j, p in enumerate(skeleton.parents) if p >= 0 and j > pelvis]
    return np.asarray(pairs, dtype=np.int64).reshape(-1, 2)


def drawn_points(motion: Motion) -> tuple[FloatArray, IntArray, IntArray]:
    """What a figure draws of a clip: points (T, J + E, 3) in file units, the joints' world positions then
    the E End Sites below the pelvis (a foot without a toe joint, a head, a hand's tip), the bones between
    them (B, 2) and each point's side colour index (J + E,) (`joint_sides`)."""
    skeleton = motion.skeleton
    rotations, positions = motion.world()  # (T, J, 3, 3), (T, J, 3)
    ends = _tip_joints(skeleton)
    tips = positions[:, ends] + np.einsum("tjab,jb->tja", rotations[:, ends], skeleton.end_sites[ends])
    tip_bones = [(joint, skeleton.num_joints + k) for k, joint in enumerate(ends)]
    pairs = np.concatenate([bones(skeleton), np.asarray(tip_bones, dtype=np.int64).reshape(-1, 2)])
    sides = joint_sides(skeleton)
    return np.concatenate([positions, tips], axis=1), pairs, np.concatenate([sides, sides[ends]])


def _tip_joints(skeleton: Skeleton) -> list[int]:
    """The joints below the pelvis whose End Sites a figure draws, in `drawn_points`' order."""
    lengths = np.linalg.norm(np.nan_to_num(skeleton.end_sites), axis=1)  # (J,), 0 where there is none
    return [j for j in range(skeleton.num_joints) if j > skeleton.pelvis and lengths[j] > 0]


def ground_height(skeleton: Skeleton, points: FloatArray) -> float:
    """The floor drawn under a clip: the lowest of its feet's points (T, J + E, 3) from `drawn_points` (each
    ankle and below, End Sites included), so a prop held below the feet does not lower it; the lowest of
    all points for a clip without feet."""
    feet = {joint for ankle in find_limbs(skeleton).ankles for joint in subtree(skeleton, int(ankle))}
    if not feet:
        return float(points[..., 1].min())
    tips = [skeleton.num_joints + k for k, joint in enumerate(_tip_joints(skeleton)) if joint in feet]
    return float(points[:, [*sorted(feet), *tips], 1].min())


def joint_sides(skeleton: Skeleton) -> IntArray:
    """(J,) 0 for centre joints, 1 for left, 2 for right (the colour index of `SIDE_COLOURS`)."""
    return np.choose(skeleton.sides() + 1, [2, 0, 1])


def project(points: FloatArray) -> FloatArray:
    """World points (..., 3) -> screen points (..., 2) of the fixed oblique orthographic camera."""
    right = np.array([math.cos(_AZIMUTH_RAD), 0.0, -math.sin(_AZIMUTH_RAD)])
    away = np.array([-math.sin(_AZIMUTH_RAD), 0.0, -math.cos(_AZIMUTH_RAD)])  # from the camera into the scene
    screen_x = points @ right
    screen_y = points[..., 1] * math.cos(_ELEVATION_RAD) + (points @ away) * math.sin(_ELEVATION_RAD)
    return np.stack([screen_x, screen_y], axis=-1)


def walking_away(clips: Sequence[FloatArray], pelvises: Sequence[int], height: float) -> list[FloatArray]:
    """Clips' drawn points (T_k, P_k, 3), cm, +Y up, each turned about the vertical through its first frame's
    pelvis (joint `pelvises[k]`) so that its travel (first frame to last) goes away from the camera (towards
    -Z, as both the viewer's and `render_clips`' cameras look): clips that walk different ways in their files
    walk the same way side by side. Clips travelling within 45 degrees of the first travelling clip's way take
    its turn, so a content and its output keep their own small difference; a clip that hardly travels (under a
    third of `height`, the tallest figure's) takes that turn too, or none where no clip travels."""
    angles = []
    for points, pelvis in zip(clips, pelvises):
        travel = points[-1, pelvis] - points[0, pelvis]
        angles.append(
            None if math.hypot(travel[0], travel[2]) < height / 3 else math.atan2(travel[0], travel[2])
        )
    first = next((angle for angle in angles if angle is not None), None)
    if first is None:
        return list(clips)
    turned_clips = []
    for points, pelvis, angle in zip(clips, pelvises, angles):
        if angle is None or abs(math.atan2(math.sin(angle - first), math.cos(angle - first))) < math.pi / 4:
            angle = first
        turn = math.pi - angle
        cosine, sine = math.cos(turn), math.sin(turn)
        origin = points[0, pelvis]
        x, z = points[..., 0] - origin[0], points[..., 2] - origin[2]
        turned = points.copy()
        turned[..., 0] = origin[0] + x * cosine + z * sine
        turned[..., 2] = origin[2] - x * sine + z * cosine
        turned_clips.append(turned)
    return turned_clips


def sample_positions(positions: FloatArray, clip_fps: float, times_s: FloatArray) -> FloatArray:
    """Joint positions (T, J, 3) at times (N,) seconds, linear between frames; held after the last frame."""
    return interpolate_rows(positions, times_s * clip_fps)  # (N, J, 3)


def grid_spacing(height: float) -> float:
    """A round grid spacing (1, 2 or 5 times a power of ten) of at most half the body height."""
    base = 10.0 ** math.floor(math.log10(max(height / 2, 1e-9)))
    return max(m * base for m in (1.0, 2.0, 5.0) if m * base <= height / 2 + 1e-9)


def _grid_segments(centre: FloatArray, ground_y: float, spacing: float, radius: float) -> FloatArray:
    """Screen segments (L, 2, 2) of ground lines within `radius` of world `centre` (3,), seen from it."""
    lines = []
    for axis in (0, 2):
        other = 2 - axis
        first, last = (
            math.floor((centre[axis] - radius) / spacing),
            math.ceil((centre[axis] + radius) / spacing),
        )
        for k in range(first, last + 1):
            ends = np.zeros((2, 3))
            ends[:, axis] = k * spacing - centre[axis]
            ends[:, other] = (-radius, radius)
            ends[:, 1] = ground_y
            lines.append(ends)
    return project(np.asarray(lines))


def _fonts() -> tuple[Any, Any]:
    """matplotlib's bundled DejaVu fonts as Pillow fonts: the label and the (monospaced) time read-out."""
    from matplotlib import font_manager
    from PIL import ImageFont

    sans = font_manager.findfont(font_manager.FontProperties(family="DejaVu Sans"))
    mono = font_manager.findfont(font_manager.FontProperties(family="DejaVu Sans Mono"))
    return ImageFont.truetype(sans, 13), ImageFont.truetype(mono, 11)


def _import_backends(mp4: bool) -> tuple[Any, Any, Any, Any, Any]:
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.collections import LineCollection
        from matplotlib.figure import Figure
        from PIL import Image, ImageDraw
    except ImportError as error:
        raise ElastyleError(
            f"rendering needs matplotlib and Pillow ({error.name} missing): {INSTALL_HINT}"
        ) from None
    if mp4:
        try:
            import imageio_ffmpeg  # noqa: F401
        except ImportError:
            raise ElastyleError(f"MP4 output needs imageio-ffmpeg: {INSTALL_HINT}") from None
    return Figure, FigureCanvasAgg, LineCollection, Image, ImageDraw


def render_clips(
    motions: Sequence[Motion],
    labels: Sequence[str],
    output: str | os.PathLike[str],
    fps: float | None = None,
    force: bool = False,
    progress: bool = True,
) -> int:
    """Render clips side by side, one panel each, to `output` (.gif or .mp4); returns the frame count.

    Clips play from time 0 together; a shorter clip holds its last frame. `fps` defaults to the fastest clip's
    rate (at most 30 for GIF). Lengths are drawn in centimetres, each clip from its own length unit (as stated
    with `--units`, else guessed from its body's height), so a clip in metres stands beside one in centimetres.
    """
    if len(motions) != len(labels):
        raise ValueError(f"{len(motions)} motions but {len(labels)} labels")
    if not motions:
        raise ElastyleError("render: no clips given")
    target = check_output_path(output, force=force)
    suffix = target.suffix.lower()
    if suffix not in (".gif", ".mp4"):
        raise UsageError(f"{target}: unknown video format {suffix or '(none)'}; use .gif or .mp4")
    fastest = max(m.fps for m in motions)
    fps = float(fps) if fps is not None else (min(fastest, 30.0) if suffix == ".gif" else fastest)
    if not fps > 0:
        raise ElastyleError(f"render: --fps must be positive, got {fps}")
    if suffix == ".gif" and fps > MAX_GIF_FPS:
        raise ElastyleError(
            f"{target}: GIF players slow down above {MAX_GIF_FPS:g} fps; lower --fps or write .mp4"
        )
    Figure, FigureCanvasAgg, LineCollection, Image, ImageDraw = _import_backends(suffix == ".mp4")

    # 1. Sample every clip at the output frame times; shorter clips hold their last frame.
    num_frames = max(int(round((m.num_frames - 1) * fps / m.fps)) + 1 for m in motions)
    times_s = np.arange(num_frames) / fps  # (N,)
    drawn = [drawn_points(m) for m in motions]  # each clip's points, bones and sides
    positions = [
        sample_positions(points * centimetres_per_unit(m.skeleton), m.fps, times_s)
        for m, (points, _, _) in zip(motions, drawn)
    ]  # each (N, J + E, 3) cm
    grounds = [ground_height(m.skeleton, p) for m, p in zip(motions, positions)]
    height = max(float(p[..., 1].max()) - g for p, g in zip(positions, grounds))
    height = height if height > 0 else 1.0
    positions = walking_away(
        positions, [m.skeleton.pelvis for m in motions], height
    )  # as the viewer turns them
    spacing = grid_spacing(height)

    # 2. One figure, one axes per panel; artists are created once and updated per frame.
    size = (PANEL_PX[0] * len(motions), PANEL_PX[1])
    figure = Figure(figsize=(size[0] / 64, size[1] / 64), dpi=64, facecolor="white")
    canvas = FigureCanvasAgg(figure)
    panels = []
    for index, motion in enumerate(motions):
        axes = figure.add_axes((index / len(motions), 0.0, 1 / len(motions), 1.0))
        axes.set_axis_off()
        axes.set_xlim(-0.6 * height, 0.6 * height)
        axes.set_ylim(-0.38 * height, 1.12 * height)
        grid = axes.add_collection(LineCollection([], colors=GRID_COLOUR, linewidths=1.0))
        (path_line,) = axes.plot([], [], color=PATH_COLOUR, linewidth=1.6)
        _, pairs, sides = drawn[index]
        colours = [SIDE_COLOURS[s] for s in sides[pairs[:, 1]]]
        lines = axes.add_collection(LineCollection([], colors=colours, linewidths=2.6, capstyle="round"))
        path = positions[index][:, motion.skeleton.pelvis].copy()  # (N, 3) pelvis path, on the ground
        path[:, 1] = grounds[index]
        panels.append((grid, path_line, lines, pairs, path))
    # Text through Pillow: matplotlib's text layout would cost two thirds of every frame.
    label_font, clock_font = _fonts()
    header = Image.new("RGB", (size[0], 24), "white")  # the labels, drawn once
    for index, label in enumerate(labels):
        name = label if len(label) <= 34 else "..." + label[-31:]
        ImageDraw.Draw(header).text(((index + 0.5) * PANEL_PX[0], 6), name, "black", label_font, "mt")

    def draw(frame: int) -> Any:
        """The frame as a Pillow RGB image."""
        for index, (grid, path_line, lines, pairs, path) in enumerate(panels):
            # follow the pelvis horizontally, each clip's own ground at the panel's floor (a clip whose floor
            # lies 89 cm below y = 0, as a rig whose origin is at its pelvis has it, was drawn out of its panel)
            centre = path[frame]
            grid.set_segments(_grid_segments(centre, 0.0, spacing, 2.5 * height))
            traced = project(path[: frame + 1] - centre)  # (frame + 1, 2)
            path_line.set_data(traced[:, 0], traced[:, 1])
            lines.set_segments(project(positions[index][frame] - centre)[pairs])  # (B, 2, 2)
        canvas.draw()
        image = Image.frombuffer("RGBA", size, canvas.buffer_rgba(), "raw", "RGBA", 0, 1).convert("RGB")
        image.paste(header, (0, 0))
        pen = ImageDraw.Draw(image)
        for index, motion in enumerate(motions):
            own = min(int(round(times_s[frame] * motion.fps)), motion.num_frames - 1)
            readout = f"t = {times_s[frame]:.2f} s  frame {own + 1}/{motion.num_frames}"
            pen.text(((index + 0.5) * PANEL_PX[0], PANEL_PX[1] - 6), readout, "black", clock_font, "mb")
            if index:
                pen.line([(index * PANEL_PX[0], 0), (index * PANEL_PX[0], PANEL_PX[1])], "#999999", 1)
        return image

    # 3. Draw every frame into the encoder, then write the file in one atomic step.
    images = (draw(frame) for frame in _progress(range(num_frames), progress, target.name))
    try:
        data = _encode_mp4(images, size, fps) if suffix == ".mp4" else _encode_gif(images, fps, Image)
    except OSError as error:
        raise OutputError(f"{target}: rendering failed: {error}") from None
    write_bytes_atomic(target, data, force=force)
    log.debug("rendered %d frames to %s", num_frames, target)
    return num_frames


def _encode_gif(images: Iterator[Any], fps: float, image_module: Any) -> bytes:
    """Quantise every frame to one shared palette and pack them into a looping GIF."""
    palette = _palette(image_module, ("#000000", "#999999", GRID_COLOUR, PATH_COLOUR, *SIDE_COLOURS))
    frames = [image.quantize(palette=palette, dither=image_module.Dither.NONE) for image in images]
    buffer = io.BytesIO()
    delays = _gif_durations_ms(len(frames), fps)
    frames[0].save(
        buffer, "GIF", save_all=True, append_images=frames[1:], loop=0, duration=delays, disposal=1
    )
    return buffer.getvalue()


def _encode_mp4(images: Iterator[Any], size: tuple[int, int], fps: float) -> bytes:
    """H.264 through the ffmpeg binary of imageio-ffmpeg, via a scratch file (ffmpeg wants to seek)."""
    import imageio_ffmpeg

    with tempfile.TemporaryDirectory(prefix="elastyle-render-") as folder:
        movie = Path(folder) / "render.mp4"
        writer = imageio_ffmpeg.write_frames(str(movie), size, fps=fps, quality=7, ffmpeg_log_level="error")
        writer.send(None)
        try:
            for image in images:
                writer.send(image.tobytes())
        finally:
            writer.close()
        return movie.read_bytes()


def _gif_durations_ms(num_frames: int, fps: float) -> list[int]:
    """Per-frame delays in whole 10 ms steps whose running sum stays on the true clock."""
    ticks = np.round(np.arange(num_frames + 1) * 100.0 / fps).astype(np.int64) * 10  # (N + 1,) ms
    return [int(d) for d in np.maximum(np.diff(ticks), 10)]


def _palette(image_module: Any, colours: Sequence[str]) -> Any:
    """One GIF palette for every frame: each drawing colour blended towards the white background."""
    from PIL import ImageColor

    blend = np.linspace(0.0, 1.0, 40)[:, None]  # (40, 1)
    swatches = [np.asarray(ImageColor.getrgb(c)[:3]) * (1 - blend) + 255 * blend for c in colours]
    strip = np.concatenate(swatches).round().astype(np.uint8)[None]  # (1, 40 * colours, 3)
    return image_module.fromarray(strip).quantize(colors=255, method=image_module.Quantize.MEDIANCUT)


def _progress(frames: range, enabled: bool, name: str) -> Any:
    if not enabled or len(frames) < 60:
        return frames
    try:
        from tqdm import tqdm
    except ImportError:
        return frames
    return tqdm(frames, desc=f"render {name}", unit="frame", leave=False, disable=None)  # a terminal only
