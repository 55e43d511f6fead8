"""The web viewer: payload and explain files, the server on 127.0.0.1, `elastyle view`, and a headless browser."""

from __future__ import annotations

import json
import re
import select
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from elastyle.errors import ElastyleError
from elastyle.io.bvh_read import read_bvh
from elastyle.io.dataset import ClipRef
from elastyle.viewer.app import allowed_hosts, build_payload, make_server, read_explain, server_url
from tests.conftest import clip_named

CHROMIUM = Path("/usr/bin/chromium")
WINDOW = (1200, 700)  # browser window; the bottom 60 px hold the controls
STYLE_CLIP = "dataset-2_walk_exhausted_005"
# The `view` command as `elastyle view` runs it, without depending on cli.py registering it.
VIEW_HARNESS = """
import argparse, sys
from elastyle.cli.view import add_view_commands
from elastyle.errors import ElastyleError
parser = argparse.ArgumentParser(prog="elastyle")
add_view_commands(parser.add_subparsers(dest="command", required=True))
args = parser.parse_args(sys.argv[1:])
try:
    sys.exit(args.run(args))
except ElastyleError as error:  # what cli.main does with it
    sys.exit(f"elastyle: error: {error}")
"""
_LOCAL = urllib.request.build_opener(urllib.request.ProxyHandler({}))  # never through a proxy


def fetch(url: str, host: str | None = None) -> tuple[int, str, bytes]:
    """Status, content type and body of a GET request."""
    request = urllib.request.Request(url, headers={"Host": host} if host else {})
    try:
        with _LOCAL.open(request, timeout=10) as response:
            return response.status, response.headers.get("Content-Type", ""), response.read()
    except urllib.error.HTTPError as error:
        return error.code, error.headers.get("Content-Type", ""), b""


@pytest.fixture
def serve() -> Iterator[Callable[[dict[str, Any]], str]]:
    """Start a viewer server in a thread on a free port; returns its URL; stopped after the test."""
    started = []

    def start(payload: dict[str, Any]) -> str:
        server = make_server(payload, 0)
        thread = threading.Thread(target=server.serve_forever, daemon=True)
        thread.start()
        started.append((server, thread))
        return server_url(server)

    yield start
    for server, thread in started:
        server.shutdown()
        server.server_close()
        thread.join(timeout=5)


def write_explain(path: Path, style_clip: str) -> Path:
    patches = [
        {
            "output_start_s": 1.0,
            "style_clip": style_clip,
            "style_mirrored": True,
            "style_start_frame": 40,
            "style_frames": 30,
            "stretch": 1.1,
            "similarity": 0.5,
            "content_start_s": 1.0,
            "mode": "blend",
            "statistics_share": 0.25,
            "parts": {
                "legs": {
                    "mismatch": 0.42,
                    "content_share": 0.6,
                    "statistics_share": 0.3,
                    "gait_mismatch": 0.4,
                },
                "left-arm": {"mismatch": 0.1, "content_share": 0.0},
            },
        },
        {
            "output_start_s": 0.0,
            "style_clip": style_clip,
            "style_mirrored": False,
            "style_start_frame": 68,
            "style_frames": 30,
            "stretch": 1.0,
            "similarity": 0.3,
        },
    ]
    path.write_text(
        json.dumps({"method": "elastic", "styles": [{"clips": [style_clip], "patches": patches}]})
    )
    return path


def test_payload_holds_positions_bones_and_sides(three_channel_bvh: Path) -> None:
    motion, _ = read_bvh(three_channel_bvh)
    payload = json.loads(json.dumps(build_payload([motion], ["tiny.bvh"])))
    clip = payload["clips"][0]
    assert clip["label"] == "tiny.bvh" and clip["num_frames"] == 3 and clip["pelvis"] == 0
    # the joints' bones, then one to each End Site (the spine's tip and the feet's, points 6 to 8)
    assert clip["bones"] == [[0, 1], [0, 2], [2, 3], [0, 4], [4, 5], [1, 6], [3, 7], [5, 8]]
    assert clip["sides"] == [0, 0, 1, 1, 2, 2, 0, 1, 2]
    positions = np.reshape(clip["positions"], (3, 9, 3))  # (T, J + E, 3)
    np.testing.assert_allclose(positions[:, :6], motion.positions(), atol=0.01)
    assert clip["ground"] == pytest.approx(positions[..., 1].min(), abs=0.01)
    assert payload["height"] == pytest.approx(positions[..., 1].max() - positions[..., 1].min(), abs=0.02)
    assert payload["explain"] is None


def test_explain_file_is_checked_and_sorted(tmp_path: Path) -> None:
    explain = read_explain(write_explain(tmp_path / "explain.json", "style.bvh"))
    starts = [p["output_start_s"] for p in explain["styles"][0]["patches"]]
    assert starts == [0.0, 1.0] and explain["source"] == "explain.json"
    assert explain["styles"][0]["patches"][1]["content_start_s"] == 1.0
    assert explain["styles"][0]["patches"][0]["content_start_s"] is None  # an older file's patch
    decided, older = explain["styles"][0]["patches"][1], explain["styles"][0]["patches"][0]
    assert decided["mode"] == "blend" and decided["statistics_share"] == 0.25
    assert decided["parts"] == {
        "legs": {"mismatch": 0.42, "content_share": 0.6, "statistics_share": 0.3},
        "left-arm": {"mismatch": 0.1, "content_share": 0.0, "statistics_share": 0.0},
    }
    assert "mode" not in older  # a file written before modes were recorded still reads
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(ElastyleError, match=r"bad\.json: not a JSON explain file"):
        read_explain(tmp_path / "bad.json")
    (tmp_path / "other.json").write_text('{"frames": 3}')
    with pytest.raises(ElastyleError, match=r"other\.json: not an explain file"):
        read_explain(tmp_path / "other.json")
    (tmp_path / "short.json").write_text('{"styles": [{"patches": [{"output_start_s": 0}]}]}')
    with pytest.raises(ElastyleError, match=r"short\.json: a patch lacks .*style_clip"):
        read_explain(tmp_path / "short.json")
    with pytest.raises(ElastyleError, match=r"missing\.json: cannot read"):
        read_explain(tmp_path / "missing.json")


def test_server_serves_page_and_json_on_loopback_only(
    three_channel_bvh: Path, serve: Callable[[dict[str, Any]], str]
) -> None:
    motion, _ = read_bvh(three_channel_bvh)
    url = serve(build_payload([motion], ["tiny.bvh"]))
    assert url.startswith("http://127.0.0.1:")
    status, kind, page = fetch(url)
    assert status == 200 and kind.startswith("text/html")
    assert b"<canvas" in page and b'fetch("clips.json")' in page
    assert not re.search(
        rb"https?://|//cdn|<script src|<link ", page
    )  # self-contained: nothing from the internet
    status, kind, body = fetch(url + "clips.json")
    assert status == 200 and kind == "application/json"
    assert json.loads(body)["clips"][0]["label"] == "tiny.bvh"
    assert fetch(url + "../etc/passwd")[0] == 404
    assert fetch(url, host="attacker.example:80")[0] == 403  # a DNS-rebound name is turned away


def test_a_taken_port_is_a_one_line_error(three_channel_bvh: Path) -> None:
    payload = build_payload([read_bvh(three_channel_bvh)[0]], ["tiny.bvh"])
    first = make_server(payload, 0)
    try:
        with pytest.raises(ElastyleError, match=r"127\.0\.0\.1:\d+ is in use; choose another --port"):
            make_server(payload, first.server_address[1])
    finally:
        first.server_close()


def test_view_command_serves_and_prints_the_url(three_channel_bvh: Path) -> None:
    command = [
        sys.executable,
        "-c",
        VIEW_HARNESS,
        "view",
        str(three_channel_bvh),
        "--no-browser",
        "--port",
        "0",
    ]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert process.stdout is not None
        ready, _, _ = select.select([process.stdout], [], [], 30)
        assert ready, "the view command printed nothing within 30 s"
        line = process.stdout.readline()
        match = re.search(r"http://127\.0\.0\.1:\d+/", line)
        assert match, line
        status, _, body = fetch(match.group(0) + "clips.json")
        assert status == 200 and json.loads(body)["clips"][0]["label"] == three_channel_bvh.name
    finally:
        process.terminate()
        process.wait(timeout=10)


def test_view_command_reports_a_missing_clip_in_one_line(tmp_path: Path) -> None:
    command = [sys.executable, "-c", VIEW_HARNESS, "view", str(tmp_path / "nope.bvh"), "--no-browser"]
    result = subprocess.run(command, capture_output=True, text=True, timeout=60)
    assert result.returncode == 1 and result.stdout == ""
    assert result.stderr.startswith("elastyle: error: ") and "nope.bvh" in result.stderr
    assert result.stderr.count("\n") == 1  # one line, no traceback


def run_chromium(
    url: str, profile: Path, *mode: str, budget: str = "2500"
) -> subprocess.CompletedProcess[str]:
    command = [
        str(CHROMIUM), "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
        "--disable-component-update", "--no-first-run", "--no-proxy-server", "--hide-scrollbars",
        f"--user-data-dir={profile}", f"--window-size={WINDOW[0]},{WINDOW[1]}", f"--virtual-time-budget={budget}",
        *mode, url,
    ]  # fmt: skip
    result = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr[-2000:]
    return result


def colour_pixels(pixels: np.ndarray, colour: str, tolerance: float = 40.0) -> int:
    """How many pixels (H, W, 3) lie within `tolerance` of a #rrggbb colour."""
    target = np.array([int(colour[i : i + 2], 16) for i in (1, 3, 5)], dtype=np.float64)
    return int(np.sum(np.linalg.norm(pixels - target, axis=-1) < tolerance))


@pytest.mark.slow
def test_headless_browser_plays_and_draws_skeletons(
    dataset_clips: list[ClipRef], serve: Callable[[dict[str, Any]], str], tmp_path: Path
) -> None:
    if not CHROMIUM.exists():
        pytest.skip(f"{CHROMIUM} not found: install chromium (apt-get install chromium) for the browser test")
    Image = pytest.importorskip("PIL.Image", reason="reading the screenshot needs Pillow")
    names = ["dataset-2_walk_normal_005", STYLE_CLIP]
    motions = [clip_named(dataset_clips, n).read()[0].slice(0, 150) for n in names]
    explain = read_explain(write_explain(tmp_path / "explain.json", f"some/where/{STYLE_CLIP}.bvh"))
    patches = explain["styles"][0]["patches"]  # from 3 s every part keeps the content's own action
    patches.append(dict(patches[1], output_start_s=3.0, content_start_s=3.0, mode="content"))
    url = serve(build_payload(motions, [n + ".bvh" for n in names], explain))

    # 1. The page loads the clips and plays: the frame counter has moved after 2.5 s of page time.
    dom = run_chromium(url, tmp_path / "profile-dom", "--dump-dom").stdout
    assert 'data-ready="1"' in dom, dom[-2000:]
    frame = re.search(r'data-frame="(\d+)"', dom)
    assert frame and int(frame.group(1)) > 30, "the timeline did not advance"
    assert f"{names[0]}.bvh  frame" in dom and f"{STYLE_CLIP}.bvh  frame" in dom
    assert f"style 1: {STYLE_CLIP}.bvh (mirrored)" in dom  # t > 1 s: the second patch
    decision = (
        "mode blend (statistics 25%)  action mismatch: legs 0.42 (content 60%, statistics 30%), left-arm 0.10"
    )
    assert decision in dom  # the patch's decision

    # 2. The screenshot shows both skeletons in their own colours on a gridded ground.
    shot = tmp_path / "view.png"
    run_chromium(url, tmp_path / "profile-shot", f"--screenshot={shot}")
    pixels = np.asarray(Image.open(shot).convert("RGB"), dtype=np.float64)  # (H, W, 3)
    assert pixels.shape[:2] == (WINDOW[1], WINDOW[0])
    scene = pixels[100 : WINDOW[1] - 60]  # below the legend, above the controls
    assert len(np.unique(scene.reshape(-1, 3), axis=0)) > 50
    for colour in ("#1f6fd1", "#d1431f", "#7b4fd8", "#e08a1e"):  # left and right bones of both clips
        assert colour_pixels(scene, colour) > 40, colour
    assert colour_pixels(scene, "#cfcfca", 6.0) > 200  # ground grid
    # the explain strip: the content's own action in grey, not in the style clip's colour as the swaps
    assert colour_pixels(pixels, "#c8c8c8", 2.0) > 1000


def test_payload_carries_foot_contacts(dataset_clips: list[ClipRef]) -> None:
    motion, _ = clip_named(dataset_clips, "dataset-2_walk_normal_005").read()
    clip = build_payload([motion], ["walk"])["clips"][0]
    names = [motion.skeleton.names[j] for j in clip["contact_points"]]
    assert names == ["Toes_L", "Foot_L", "Toes_R", "Foot_R"]  # each foot's toe and heel
    contacts = np.array(clip["contacts"]).reshape(motion.num_frames, 2, 2)
    assert np.all((0.3 < contacts.mean(axis=0)) & (contacts.mean(axis=0) < 0.9))  # planted part of a cycle


def test_explain_carries_part_styles_a_transitions_share_and_backward_windows(tmp_path: Path) -> None:
    """What the page's explain panel shows beside the style's own patches (before, a part's style clip, a
    second style's share and a window played backwards were not sent to it)."""
    path = write_explain(tmp_path / "explain.json", "style.bvh")
    record = json.loads(path.read_text())
    part = dict(record["styles"][0], patches=[dict(p, style_clip="/x/arms.bvh", style_backwards=True)
                                              for p in record["styles"][0]["patches"]])  # fmt: skip
    record |= {"part_styles": [dict(part, parts=["left-arm", "right-arm"])], "model_fps": 30.0,
               "second_weight": {"times_s": [3.0, 5.0], "values": [0.0, 1.0]}, "output": "/x/out.bvh"}  # fmt: skip
    path.write_text(json.dumps(record))
    explain = read_explain(path)
    [arms] = explain["part_styles"]
    assert arms["parts"] == ["left-arm", "right-arm"] and {p["style_clip"] for p in arms["patches"]} == {
        "arms.bvh"
    }
    assert all(p["style_backwards"] for p in arms["patches"])
    assert not any(p["style_backwards"] for p in explain["styles"][0]["patches"])  # older files: forwards
    assert explain["second_weight"] == {"times_s": [3.0, 5.0], "values": [0.0, 1.0]}
    assert explain["output"] == "out.bvh" and explain["output_path"] == "/x/out.bvh"
    assert "output_path" not in build_payload([], [], explain)["explain"]  # no folder goes to the page
    for bad, message in (
        ({"times_s": [1.0]}, "'second_weight' lacks"),
        (None, "'model_fps' must be a positive"),
    ):
        broken = record | ({"second_weight": bad} if bad else {"model_fps": None})
        path.write_text(json.dumps(broken))
        with pytest.raises(ElastyleError, match=rf"explain\.json: {message}"):
            read_explain(path)


def test_the_page_on_port_80_is_served_to_a_browser_and_asks_for_no_icon(
    three_channel_bvh: Path, serve: Callable[[dict[str, Any]], str]
) -> None:
    # a browser sends "Host: 127.0.0.1" to port 80, without the port: the page was refused (403)
    assert "127.0.0.1" in allowed_hosts(80) and "127.0.0.1" not in allowed_hosts(8765)
    assert "127.0.0.1:8765" in allowed_hosts(8765) and "example.org" not in allowed_hosts(80)
    url = serve(build_payload([read_bvh(three_channel_bvh)[0]], ["tiny.bvh"]))
    assert fetch(url + "favicon.ico")[0] == 204  # every page load asked for it: a 404 in the console


def _view_payload(*arguments: str) -> tuple[str, dict[str, Any]]:
    """Run `elastyle view ... --no-browser --port 0` until it serves: its stderr and the page's data."""
    command = [sys.executable, "-c", VIEW_HARNESS, "view", *arguments, "--no-browser", "--port", "0"]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert process.stdout is not None and process.stderr is not None
        ready, _, _ = select.select([process.stdout], [], [], 30)
        assert ready, "the view command printed nothing within 30 s"
        match = re.search(r"http://127\.0\.0\.1:\d+/", process.stdout.readline())
        assert match
        payload = json.loads(fetch(match.group(0) + "clips.json")[2])
    finally:
        process.terminate()
        process.wait(timeout=10)
    return process.stderr.read(), payload


def _view_stderr(*arguments: str) -> tuple[str, list[str]]:
    """`_view_payload`'s stderr and the clips' labels."""
    stderr, payload = _view_payload(*arguments)
    return stderr, [clip["label"] for clip in payload["clips"]]


def test_view_takes_folders_and_globs_and_tells_files_of_one_name_apart(
    three_channel_bvh: Path, tmp_path: Path
) -> None:
    for folder in ("v1", "v2"):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "out.bvh").write_text(three_channel_bvh.read_text())
    explain = write_explain(tmp_path / "explain.json", "style.bvh")
    record = json.loads(explain.read_text())
    explain.write_text(json.dumps(record | {"output": str(tmp_path / "v2" / "out.bvh")}))
    # a folder and a quoted glob, as transfer takes them (both were "not a file")
    stderr, labels = _view_stderr(
        str(tmp_path / "v1"), str(tmp_path / "v*" / "out.bvh"), "--explain", str(explain)
    )
    assert labels == ["v1/out.bvh", "v1/out.bvh (2)", "v2/out.bvh"]  # one file twice, numbered
    assert "written for" not in stderr  # v2/out.bvh is shown (its name alike v1's had it warned of)
    stderr, _ = _view_stderr(str(tmp_path / "v1" / "out.bvh"), "--explain", str(explain))
    assert f"was written for {tmp_path / 'v2' / 'out.bvh'}, which is not among the clips shown" in stderr
    bracketed = (
        tmp_path / "take[1].bvh"
    )  # glob characters in a file's name: that file (it was "no clips found")
    bracketed.write_text(three_channel_bvh.read_text())
    assert _view_stderr(str(bracketed))[1] == ["take[1].bvh"]
    # an older file's path, relative to where transfer ran: matched by name, as before
    explain.write_text(json.dumps(record | {"output": "results/out.bvh"}))
    stderr, _ = _view_stderr(str(tmp_path / "v1" / "out.bvh"), "--explain", str(explain))
    assert "written for" not in stderr


def test_explain_shows_style_clips_by_name_only(tmp_path: Path) -> None:
    explain = read_explain(write_explain(tmp_path / "explain.json", "/home/someone/private/style.bvh"))
    assert {p["style_clip"] for p in explain["styles"][0]["patches"]} == {"style.bvh"}


def test_idle_and_flooding_connections_are_bounded_and_closed(
    three_channel_bvh: Path, monkeypatch: pytest.MonkeyPatch, capfd: pytest.CaptureFixture[str]
) -> None:
    import socket

    from elastyle.viewer import app

    monkeypatch.setattr(app, "IDLE_TIMEOUT_S", 0.5)
    motion, _ = read_bvh(three_channel_bvh)
    server = make_server(build_payload([motion] * 40, ["tiny.bvh"] * 40), 0)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    port = server.server_address[1]
    try:
        before = threading.active_count()
        flood = [socket.create_connection(("127.0.0.1", port)) for _ in range(60)]  # idle: send nothing
        time.sleep(0.2)
        assert threading.active_count() - before <= app.MAX_CONNECTIONS
        time.sleep(1.0)  # past the idle timeout: the server has closed them
        for s in flood:
            s.settimeout(3.0)  # a connection left open fails the test instead of hanging it
        assert all(s.recv(16) == b"" for s in flood)
        for s in flood:
            s.close()
        # a client that asks for the payload and hangs up at once: no traceback anywhere
        for _ in range(5):
            rude = socket.create_connection(("127.0.0.1", port))
            rude.sendall(f"GET /clips.json HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n".encode())
            rude.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, b"\x01\x00\x00\x00\x00\x00\x00\x00")
            rude.close()
        time.sleep(0.3)
        assert fetch(server_url(server) + "clips.json")[0] == 200  # still serving
    finally:
        server.shutdown()
        server.server_close()
        thread.join(timeout=5)
    assert "Traceback" not in capfd.readouterr().err


@pytest.mark.slow
def test_headless_browser_plays_a_glb(
    dataset_clips: list[ClipRef], serve: Callable[[dict[str, Any]], str], tmp_path: Path
) -> None:
    """glTF out, read back and shown moving: the viewer plays a .glb (the frame counter advances, the
    skeleton is drawn in its colours, a foot moves on screen between two moments)."""
    if not CHROMIUM.exists():
        pytest.skip(f"{CHROMIUM} not found: install chromium (apt-get install chromium) for the browser test")
    Image = pytest.importorskip("PIL.Image", reason="reading the screenshot needs Pillow")
    from elastyle.io.clip_write import write_clip
    from elastyle.io.dataset import read_clip

    path = tmp_path / "walk.glb"
    write_clip(path, clip_named(dataset_clips, "dataset-2_walk_normal_005").read()[0].slice(0, 150))
    motion, _ = read_clip(path)
    url = serve(build_payload([motion], ["walk.glb"]))
    dom = run_chromium(url, tmp_path / "profile-dom", "--dump-dom").stdout
    assert 'data-ready="1"' in dom and "walk.glb  frame" in dom
    frame = re.search(r'data-frame="(\d+)"', dom)
    assert frame and int(frame.group(1)) > 30, "the timeline did not advance"
    shots = []
    for budget in ("500", "1500"):
        shot = tmp_path / f"view{budget}.png"
        run_chromium(url, tmp_path / f"profile-{budget}", f"--screenshot={shot}", budget=budget)
        shots.append(np.asarray(Image.open(shot).convert("RGB"), dtype=np.float64)[100 : WINDOW[1] - 60])
    for colour in ("#1f6fd1", "#d1431f"):  # left and right bones
        assert colour_pixels(shots[1], colour) > 40, colour
    moved = [
        np.argwhere(np.linalg.norm(shot - np.array([0x1F, 0x6F, 0xD1]), axis=-1) < 40).mean(axis=0)
        for shot in shots
    ]
    assert np.linalg.norm(moved[1] - moved[0]) > 2.0  # the left side's pixels moved between 0.5 s and 1.5 s


def test_the_floor_lies_under_the_feet_whatever_else_hangs_low(dataset_clips: list[ClipRef]) -> None:
    """A prop hanging 1 m below the pelvis, far below the feet: the floor drawn is the feet's."""
    from elastyle.core.motion import Motion
    from elastyle.core.skeleton import Skeleton

    walk = clip_named(dataset_clips, "dataset-2_walk_normal_005").read()[0]
    skeleton = walk.skeleton
    pelvis = skeleton.pelvis
    below = walk.world([pelvis])[0][0, pelvis].T @ np.array([0.0, -100.0, 0.0])  # down, in the pelvis's frame
    armed = Motion(
        Skeleton(
            (*skeleton.names, "Prop"), np.append(skeleton.parents, pelvis), np.vstack([skeleton.offsets, below]),
            np.vstack([skeleton.end_sites, below]),
        ),
        np.concatenate([walk.rotations, np.zeros((walk.num_frames, 1, 3))], axis=1),
        np.concatenate([walk.translations, np.broadcast_to(below, (walk.num_frames, 1, 3))], axis=1),
        walk.fps,
    )  # fmt: skip
    assert armed.positions()[:, -1, 1].max() < walk.positions()[:, skeleton.index("Toes_R"), 1].min() - 5
    grounds = [build_payload([motion], ["clip"])["clips"][0]["ground"] for motion in (walk, armed)]
    assert grounds[1] == pytest.approx(grounds[0])


def test_view_warns_of_an_explain_file_written_for_another_output(
    three_channel_bvh: Path, tmp_path: Path
) -> None:
    """An explain file names the output it was written for; shown beside other clips, it is said, in the
    terminal and on the page (before: its patches were drawn on a clip they do not describe without a word)."""
    explain = write_explain(tmp_path / "explain.json", "style.bvh")
    record = json.loads(explain.read_text())
    record["output"] = "/some/folder/styled_walk.bvh"
    explain.write_text(json.dumps(record))
    assert read_explain(explain)["output"] == "styled_walk.bvh"  # the name only: no folder goes out
    stderr, payload = _view_payload(str(three_channel_bvh), "--explain", str(explain))
    assert (
        "explain.json was written for /some/folder/styled_walk.bvh, which is not among the clips shown"
        in stderr
    )
    # and on the page, by the file's name alone (it said nothing there)
    warning = payload["explain"]["warning"]
    assert warning.startswith("written for styled_walk.bvh, which is not among") and "/some" not in warning


def test_view_tells_clips_apart_under_folders_of_one_name_and_style_clips_of_one_name(
    three_channel_bvh: Path, tmp_path: Path
) -> None:
    """Clips in v1/clips/ and v2/clips/ were both labelled clips/walk.bvh, the page taking the content for
    the output; two style clips named take1.bvh in two folders were both shown as take1.bvh, every patch
    drawn in the first one's colour."""
    for folder in ("v1/clips", "v2/clips", "lib/active", "lib/elderly"):
        (tmp_path / folder).mkdir(parents=True)
    for path in ("v1/clips/walk.bvh", "v2/clips/walk.bvh", "lib/active/take1.bvh", "lib/elderly/take1.bvh"):
        (tmp_path / path).write_text(three_channel_bvh.read_text())
    # the style clips as transfer records them: relative to where it ran (the viewer runs elsewhere)
    explain = write_explain(tmp_path / "explain.json", "lib/active/take1.bvh")
    record = json.loads(explain.read_text())
    record["styles"][0]["patches"][0]["style_clip"] = "lib/elderly/take1.bvh"  # at 1 s
    record |= {"output": str(tmp_path / "v2/clips/walk.bvh"), "working_folder": str(tmp_path)}
    explain.write_text(json.dumps(record))
    shown = [
        tmp_path / p
        for p in ("v1/clips/walk.bvh", "v2/clips/walk.bvh", "lib/active/take1.bvh", "lib/elderly/take1.bvh")
    ]
    stderr, payload = _view_payload(*map(str, shown), "--explain", str(explain))
    labels = [clip["label"] for clip in payload["clips"]]
    assert labels == ["v1/clips/walk.bvh", "v2/clips/walk.bvh", "active/take1.bvh", "elderly/take1.bvh"]
    assert payload["explain"]["output"] == "v2/clips/walk.bvh"  # the output, not the content
    sources = [row["style_clip"] for row in payload["explain"]["styles"][0]["patches"]]
    assert sources == ["active/take1.bvh", "elderly/take1.bvh"]
    assert str(tmp_path) not in json.dumps(payload)  # no more of the user's folders than tells clips apart
    # the style clips not shown: told apart among themselves
    _, alone = _view_payload(str(shown[1]), "--explain", str(explain))
    assert [row["style_clip"] for row in alone["explain"]["styles"][0]["patches"]] == sources


def test_labels_tell_every_clip_apart() -> None:
    from elastyle.viewer.app import distinct_labels

    assert distinct_labels(["a/w.bvh", "a/w.bvh", "a/w.bvh"]) == ["w.bvh", "w.bvh (2)", "w.bvh (3)"]
    assert distinct_labels(["x/w.bvh", "x/w.bvh", "y/w.bvh (2)"]) == ["w.bvh", "w.bvh (3)", "w.bvh (2)"]
    assert distinct_labels(["/walk.bvh", "/data/walk.bvh"]) == ["/walk.bvh", "data/walk.bvh"]
    assert distinct_labels(["C:\\clips\\walk.bvh", "D:\\clips\\walk.bvh", "D:\\run.bvh"]) == [
        "C:/clips/walk.bvh", "D:/clips/walk.bvh", "run.bvh",
    ]  # fmt: skip


def test_clips_walk_away_side_by_side_and_overlaid_start_together(
    dataset_clips: list[ClipRef], serve: Callable[[dict[str, Any]], str], tmp_path: Path
) -> None:
    """Two takes that walk opposite ways in their files (one turned half round and set 5 m aside)
    are turned to walk the same way, away from the camera, in the viewer's payload as in `render`; overlaid,
    each starts where the other does (the turned take's figure had been drawn off the floor, out of the picture)."""
    from dataclasses import replace

    walk, other = (
        clip_named(dataset_clips, f"dataset-2_walk_{n}").read()[0].slice(0, 150)
        for n in ("normal_005", STYLE_CLIP[15:])
    )
    rotations, translations = other.rotations.copy(), other.translations.copy()
    rotations[:, 0] = [0.0, np.pi, 0.0]  # the static root turned half round, moved 5 m aside
    translations[:, 0] = [500.0, 0.0, 0.0]
    turned = replace(other, rotations=rotations, translations=translations)
    payload = build_payload([walk, turned], ["walk.bvh", "turned.bvh"])
    for clip in payload["clips"]:
        points = np.reshape(clip["positions"], (clip["num_frames"], -1, 3))
        travel = points[-1, clip["pelvis"]] - points[0, clip["pelvis"]]
        assert travel[2] < -0.9 * np.linalg.norm(travel[[0, 2]]), travel  # away from the camera
    if not CHROMIUM.exists():
        pytest.skip(f"{CHROMIUM} not found: install chromium (apt-get install chromium) for the browser test")
    Image = pytest.importorskip("PIL.Image", reason="reading the screenshot needs Pillow")
    shot = tmp_path / "overlay.png"
    url = serve(payload) + "?overlay=1&t=2&paused=1"
    run_chromium(url, tmp_path / "profile-overlay", f"--screenshot={shot}")
    scene = np.asarray(Image.open(shot).convert("RGB"), dtype=np.float64)[100 : WINDOW[1] - 60]
    for colour in ("#1f6fd1", "#d1431f", "#7b4fd8", "#e08a1e"):  # left and right bones of both clips
        assert colour_pixels(scene, colour) > 40, colour
