"""The viewer's server: clips as JSON plus one static page, on 127.0.0.1 only.

`build_payload` turns clips into plain JSON data (world joint positions (T, J, 3) in file units, flattened);
`make_server` serves `/` (`page.html` beside this module: inline JavaScript drawing on a <canvas>, nothing fetched from the
internet) and `/clips.json`. The caller runs `serve_forever` and decides about printing and browsers.
"""

from __future__ import annotations

import errno
import json
import logging
import os
import threading
from collections import Counter
from collections.abc import Sequence
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path, PurePath
from typing import Any
from urllib.parse import urlsplit

import numpy as np

from elastyle.core.body import centimetres_per_unit
from elastyle.core.motion import Motion
from elastyle.errors import ElastyleError
from elastyle.viewer.render import drawn_points, grid_spacing, ground_height, walking_away

log = logging.getLogger("elastyle")

HOST = "127.0.0.1"
IDLE_TIMEOUT_S = 10.0
MAX_CONNECTIONS = 16
PAGE_PATH = Path(__file__).resolve().parent / "page.html"  # the page: inline JavaScript on a <canvas>
_PATCH_FIELDS = (
    ("output_start_s", float),
    ("style_clip", str),
    ("style_mirrored", bool),
    ("style_start_frame", int),
    ("style_frames", int),
    ("stretch", float),
    ("similarity", float),
)
# fields older explain files lack, with what they meant then
_OPTIONAL_FIELDS = (("style_backwards", bool, False), ("content_start_s", float, None))


def distinct_labels(paths: Sequence[str]) -> list[str]:
    """A label per clip path (N,): its file name, with as many of its folders before it as tell it from the
    others' (`v1/clips/walk.bvh` and `v2/clips/walk.bvh` are `v1/clips/walk.bvh` and `v2/clips/walk.bvh`, a
    lone `take1.bvh` stays `take1.bvh`); a path given twice is numbered. No more of the user's folders than
    that goes to the page."""
    parts = [PurePath(str(path).replace("\\", "/")).parts for path in paths]
    labels = []
    for index, own in enumerate(parts):
        others = [other for k, other in enumerate(parts) if k != index and other != own]
        depth = 1
        while depth < len(own) and any(other[-depth:] == own[-depth:] for other in others):
            depth += 1
        labels.append(PurePath(*own[-depth:]).as_posix())
    given = Counter(labels)
    numbered: Counter[str] = Counter()
    for index, label in enumerate(labels):
        numbered[label] += 1
        if given[label] > 1 and numbered[label] > 1:
            count = numbered[label]
            while f"{label} ({count})" in given:  # a file of that name too
                count += 1
            labels[index] = f"{label} ({count})"
    return labels


def build_payload(
    motions: Sequence[Motion], labels: Sequence[str], explain: dict[str, Any] | None = None
) -> dict[str, Any]:
    """JSON-ready data for the page: per clip its label, fps, bones, sides, pelvis path and positions."""
    if len(motions) != len(labels):
        raise ValueError(f"{len(motions)} motions but {len(labels)} labels")
    drawn = [drawn_points(motion) for motion in motions]  # each clip's joints, then its End Sites
    positions = [points * centimetres_per_unit(m.skeleton) for m, (points, _, _) in zip(motions, drawn)]
    grounds = [ground_height(m.skeleton, p) for m, p in zip(motions, positions)]  # (T, J + E, 3) cm, +Y up
    height = max((float(p[..., 1].max()) - g for p, g in zip(positions, grounds)), default=0.0)
    height = height if height > 0 else 1.0
    turned = walking_away(positions, [m.skeleton.pelvis for m in motions], height)
    clips = [
        {
            "label": label,
            "fps": float(motion.fps),
            "num_frames": motion.num_frames,
            "pelvis": motion.skeleton.pelvis,
            "ground": ground,
            "bones": pairs.tolist(),  # (B, 2) parent, child
            "sides": sides.tolist(),  # (J + E,) 0 centre, 1 left, 2 right
            "positions": np.round(points, 2).ravel().tolist(),  # (T * (J + E) * 3,)
            **_contacts(motion),
        }
        for motion, label, (_, pairs, sides), points, ground in zip(motions, labels, drawn, turned, grounds)
    ]
    if explain is not None:  # the page gets the output's label: no more of the user's folders goes out
        private = ("output_path", "style_paths", "working_folder")
        explain = {key: value for key, value in explain.items() if key not in private}
    return {"clips": clips, "height": height, "grid_spacing": grid_spacing(height), "explain": explain}


def _contacts(motion: Motion) -> dict[str, Any]:
    """Each foot's toe and heel (ankle) joints (F * 2,) and their planted frames (T * F * 2,) as 0/1, from
    `steps.contacts.detect_point_contacts`; none if no legs."""
    from elastyle.core.body import find_limbs
    from elastyle.steps.contacts import contact_points, detect_point_contacts

    limbs = find_limbs(motion.skeleton)
    if len(limbs.toes) == 0:
        return {"contact_points": [], "contacts": []}
    points = contact_points(limbs)  # (F, 2) toe, heel
    contacts = detect_point_contacts(motion).astype(np.int8)  # (T, F, 2)
    return {"contact_points": points.ravel().tolist(), "contacts": contacts.ravel().tolist()}


def read_explain(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The patch records of an `elastyle transfer --explain` file, each style track sorted by output time."""
    try:
        record = json.loads(Path(path).read_text(encoding="utf-8"))
    except OSError as error:
        raise ElastyleError(f"{path}: cannot read explain file: {error.strerror or error}") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise ElastyleError(f"{path}: not a JSON explain file ({error})") from None
    styles = record.get("styles") if isinstance(record, dict) else None
    if not isinstance(styles, list):
        raise ElastyleError(
            f"{path}: not an explain file (no 'styles' list; write one with transfer --explain)"
        )
    parts = record.get("part_styles") or []
    if not isinstance(parts, list):
        raise ElastyleError(f"{path}: 'part_styles' is not a list")
    output = record.get("output")  # the output file it was written for (older files do not say)
    tracks = [_track(style, path) for style in styles]
    # the body parts another style gave their manner, each with its own track
    part_tracks = [
        _track(entry, path) | {"parts": [str(part) for part in entry.get("parts", [])]} for entry in parts
    ]
    # the style clips by label (`distinct_labels`), each label's path as recorded
    recorded = list(
        dict.fromkeys(row["style_clip"] for track in tracks + part_tracks for row in track["patches"])
    )
    label_of = dict(zip(recorded, distinct_labels(recorded)))
    for track in tracks + part_tracks:
        for row in track["patches"]:
            row["style_clip"] = label_of[row["style_clip"]]
    return {
        "source": Path(path).name,
        "styles": tracks,
        "part_styles": part_tracks,
        "second_weight": _second_weight(record.get("second_weight"), path),
        "model_fps": _model_fps(record.get("model_fps", 30.0), path),
        "output": PurePath(str(output)).name if output else None,  # what the page shows of it
        "output_path": str(output)
        if output
        else None,  # as the transfer recorded it, for the caller's checks
        "style_paths": {label: path for path, label in label_of.items()},  # likewise
        # where the transfer ran: the recorded style clips' relative paths start there (older files: unknown)
        "working_folder": str(record["working_folder"]) if record.get("working_folder") else None,
    }


def _track(style: Any, path: str | os.PathLike[str]) -> dict[str, Any]:
    """One style's patches from an explain record, sorted by output time, its clips as recorded."""
    patches = style.get("patches") if isinstance(style, dict) else None
    if not isinstance(patches, list):
        raise ElastyleError(f"{path}: a style entry has no 'patches' list")
    try:
        rows = [
            {key: kind(patch[key]) for key, kind in _PATCH_FIELDS}
            | {
                key: patch[key] if patch.get(key) is None else kind(patch[key])
                for key, kind, _ in _OPTIONAL_FIELDS
                if key in patch
            }  # fmt: skip
            | {key: default for key, _, default in _OPTIONAL_FIELDS if key not in patch}
            | _decision(patch)
            for patch in patches
        ]
    except (KeyError, TypeError, ValueError) as error:
        raise ElastyleError(f"{path}: a patch lacks or mangles field {error}") from None
    return {"patches": sorted(rows, key=lambda row: row["output_start_s"])}


def _model_fps(value: Any, path: str | os.PathLike[str]) -> float:
    """The model's frame rate the patches' frames count in: a positive number."""
    try:
        fps = float(value)
    except (TypeError, ValueError):
        fps = float("nan")
    if not fps > 0 or not np.isfinite(fps):
        raise ElastyleError(f"{path}: 'model_fps' must be a positive number, got {value!r:.40}")
    return fps


def _second_weight(weight: Any, path: str | os.PathLike[str]) -> dict[str, list[float]] | None:
    """A transition's or blend's share of the second style over content seconds, or None."""
    if weight is None:
        return None
    try:
        times, values = [float(t) for t in weight["times_s"]], [float(v) for v in weight["values"]]
    except (KeyError, TypeError, ValueError):
        raise ElastyleError(f"{path}: 'second_weight' lacks its times_s and values") from None
    if len(times) != len(values) or not times:
        raise ElastyleError(f"{path}: 'second_weight' has {len(times)} times and {len(values)} values")
    return {"times_s": times, "values": values}


def _decision(patch: dict[str, Any]) -> dict[str, Any]:
    """What the transfer decided for a patch, where the explain file records it (older files do not): the
    mode (swap, blend, statistics or content), the statistics' share, and per body part its action mismatch,
    the share of the content's own action kept and of the style's statistics on it."""
    if "mode" not in patch:
        return {}
    parts = patch.get("parts") or {}
    return {
        "mode": str(patch["mode"]),
        "statistics_share": float(patch.get("statistics_share", 0.0)),
        "parts": {
            str(name): {
                "mismatch": float(part["mismatch"]),
                "content_share": float(part["content_share"]),
                "statistics_share": float(part.get("statistics_share", 0.0)),
            }
            for name, part in parts.items()
        },
    }


def make_server(payload: dict[str, Any], port: int = 0) -> ThreadingHTTPServer:
    """An HTTP server on 127.0.0.1:`port` (0 = any free port) serving the page and the payload."""
    body = json.dumps(payload, separators=(",", ":")).encode("utf-8")
    page = PAGE_PATH.read_bytes()

    class Handler(BaseHTTPRequestHandler):
        timeout = IDLE_TIMEOUT_S  # a connection that sends nothing for this long is closed

        def do_GET(self) -> None:  # noqa: N802 (http.server's name)
            host = self.headers.get("Host")
            if host is not None and host not in allowed_hosts(server_port(self.server)):
                self._send(403, "text/plain", b"forbidden host\n")  # a rebound DNS name, not the user
                return
            path = urlsplit(self.path).path
            if path in ("/", "/index.html"):
                self._send(200, "text/html; charset=utf-8", page)
            elif path == "/clips.json":
                self._send(200, "application/json", body)
            elif path == "/favicon.ico":  # browsers ask for one on every load: none, and no error
                self._send(204, "image/x-icon", b"")
            else:
                self._send(404, "text/plain", b"not found\n")

        def _send(self, status: int, kind: str, data: bytes) -> None:
            self.send_response(status)
            self.send_header("Content-Type", kind)
            self.send_header("Content-Length", str(len(data)))
            self.send_header("Cache-Control", "no-store")
            self.send_header("X-Content-Type-Options", "nosniff")
            self.send_header(
                "Content-Security-Policy",
                "default-src 'self'; script-src 'unsafe-inline'; style-src 'unsafe-inline'",
            )
            self.end_headers()
            try:
                self.wfile.write(data)
            except (BrokenPipeError, ConnectionResetError):  # the browser went away mid-response
                self.close_connection = True

        def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 (http.server's name)
            log.debug("view: " + format, *args)

    try:
        server = _BoundedServer((HOST, port), Handler)
    except OSError as error:
        if error.errno == errno.EADDRINUSE:
            raise ElastyleError(
                f"{HOST}:{port} is in use; choose another --port (0 picks a free one)"
            ) from None
        raise ElastyleError(f"cannot serve on {HOST}:{port}: {error.strerror or error}") from None
    server.daemon_threads = True
    return server


class _BoundedServer(ThreadingHTTPServer):
    """At most `MAX_CONNECTIONS` requests served at once (more are closed at once, not queued on threads);
    a client that disconnects is logged at debug level, not printed as a traceback."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._slots = threading.BoundedSemaphore(MAX_CONNECTIONS)

    def process_request(self, request: Any, client_address: Any) -> None:
        if not self._slots.acquire(blocking=False):
            self.shutdown_request(request)
            return
        try:
            super().process_request(request, client_address)
        except BaseException:
            self._slots.release()
            raise

    def process_request_thread(self, request: Any, client_address: Any) -> None:
        try:
            super().process_request_thread(request, client_address)
        finally:
            self._slots.release()

    def handle_error(self, request: Any, client_address: Any) -> None:
        log.debug("view: connection from %s ended with an error", client_address, exc_info=True)


def allowed_hosts(port: int) -> set[str]:
    """The Host headers a request to this machine's viewer on `port` carries (a browser leaves out port 80)."""
    names = {HOST, "localhost"}
    return {f"{name}:{port}" for name in names} | (names if port == 80 else set())


def server_port(server: Any) -> int:
    """The port a server bound (useful after asking for port 0)."""
    return int(server.server_address[1])


def server_url(server: ThreadingHTTPServer) -> str:
    return f"http://{HOST}:{server_port(server)}/"
