"""The viewer's server: clips as JSON plus one static page, on 127.0.0.1 only.

`build_payload` turns clips into plain JSON data (world joint positions (T, J, 3) in file units, flattened);
`make_server` serves `/` (the page below: inline JavaScript drawing on a <canvas>, nothing fetched from the
internet) and `/clips.json`. The caller runs `serve_forever` and decides about printing and browsers.
"""

from __future__ import annotations

import errno
import json
import logging
import os
from collections.abc import Sequence
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

import numpy as np

from elastyle.core.motion import Motion
from elastyle.errors import ElastyleError
from elastyle.viewer.render import bones, grid_spacing, joint_sides

log = logging.getLogger("elastyle")

HOST = "127.0.0.1"
_PATCH_FIELDS = (
    ("output_start_s", float),
    ("style_clip", str),
    ("style_mirrored", bool),
    ("style_start_frame", int),
    ("style_frames", int),
    ("stretch", float),
    ("similarity", float),
)


def build_payload(
    motions: Sequence[Motion], labels: Sequence[str], explain: dict[str, Any] | None = None
) -> dict[str, Any]:
    """JSON-ready data for the page: per clip its label, fps, bones, sides, pelvis path and positions."""
    if len(motions) != len(labels):
        raise ValueError(f"{len(motions)} motions but {len(labels)} labels")
    clips = []
    height = 0.0
    for motion, label in zip(motions, labels):
        positions = motion.positions()  # (T, J, 3) file units, +Y up
        ground = float(positions[..., 1].min())
        height = max(height, float(positions[..., 1].max()) - ground)
        clips.append(
            {
                "label": label,
                "fps": float(motion.fps),
                "num_frames": motion.num_frames,
                "pelvis": motion.skeleton.pelvis,
                "ground": ground,
                "bones": bones(motion.skeleton).tolist(),  # (B, 2) parent, child
                "sides": joint_sides(motion.skeleton).tolist(),  # (J,) 0 centre, 1 left, 2 right
                "positions": np.round(positions, 2).ravel().tolist(),  # (T * J * 3,)
                **_contacts(motion),
            }
        )
    height = height if height > 0 else 1.0
    return {"clips": clips, "height": height, "grid_spacing": grid_spacing(height), "explain": explain}


def _contacts(motion: Motion) -> dict[str, Any]:
    """Toe joints (F,) and their planted frames (T * F,) as 0/1, from `cleanup.detect_contacts`; none if no legs."""
    from elastyle.core.body import find_limbs
    from elastyle.steps.cleanup import detect_contacts

    toes = find_limbs(motion.skeleton).toes
    if len(toes) == 0:
        return {"toes": [], "contacts": []}
    return {"toes": toes.tolist(), "contacts": detect_contacts(motion).astype(np.int8).ravel().tolist()}


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
    tracks = []
    for style in styles:
        patches = style.get("patches") if isinstance(style, dict) else None
        if not isinstance(patches, list):
            raise ElastyleError(f"{path}: a style entry has no 'patches' list")
        try:
            rows = [{key: kind(patch[key]) for key, kind in _PATCH_FIELDS} for patch in patches]
        except (KeyError, TypeError, ValueError) as error:
            raise ElastyleError(f"{path}: a patch lacks or mangles field {error}") from None
        tracks.append({"patches": sorted(rows, key=lambda row: row["output_start_s"])})
    return {"source": Path(path).name, "styles": tracks}


def make_server(payload: dict[str, Any], port: int = 0) -> ThreadingHTTPServer:
    """An HTTP server on 127.0.0.1:`port` (0 = any free port) serving the page and the payload."""
    body = json.dumps(payload, separators=(",", ":")).encode("utf-8")
    page = PAGE.encode("utf-8")

    class Handler(BaseHTTPRequestHandler):
        def do_GET(self) -> None:  # noqa: N802 (http.server's name)
            bound = server_port(self.server)
            host = self.headers.get("Host")
            if host is not None and host not in (f"{HOST}:{bound}", f"localhost:{bound}"):
                self._send(403, "text/plain", b"forbidden host\n")  # a rebound DNS name, not the user
                return
            path = urlsplit(self.path).path
            if path in ("/", "/index.html"):
                self._send(200, "text/html; charset=utf-8", page)
            elif path == "/clips.json":
                self._send(200, "application/json", body)
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
            self.wfile.write(data)

        def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 (http.server's name)
            log.debug("view: " + format, *args)

    try:
        server = ThreadingHTTPServer((HOST, port), Handler)
    except OSError as error:
        if error.errno == errno.EADDRINUSE:
            raise ElastyleError(
                f"{HOST}:{port} is in use; choose another --port (0 picks a free one)"
            ) from None
        raise ElastyleError(f"cannot serve on {HOST}:{port}: {error.strerror or error}") from None
    server.daemon_threads = True
    return server


def server_port(server: Any) -> int:
    """The port a server bound (useful after asking for port 0)."""
    return int(server.server_address[1])


def server_url(server: ThreadingHTTPServer) -> str:
    return f"http://{HOST}:{server_port(server)}/"


PAGE = r"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>elastyle view</title>
<style>
html,body{margin:0;height:100%;font:13px system-ui,sans-serif;background:#f7f7f5;color:#222;overflow:hidden}
#stage{position:absolute;left:0;top:0;right:0;bottom:60px}
#view{width:100%;height:100%;display:block;cursor:grab;touch-action:none}
#bar{position:absolute;left:0;right:0;bottom:0;height:60px;background:#fff;border-top:1px solid #ddd;
 padding:6px 10px;box-sizing:border-box}
#row{display:flex;align-items:center;gap:10px}
#slider{flex:1}
#readout{font-family:monospace;white-space:pre;min-width:220px}
#legend,#explain{position:absolute;top:8px;background:rgba(255,255,255,.88);padding:6px 8px;border-radius:4px}
#legend{left:8px}
#legend div{margin:2px 0}
#explain{right:8px;max-width:48%;font:12px monospace;white-space:pre;display:none}
#strip{width:100%;height:14px;display:block;margin-top:5px}
.swatch{display:inline-block;width:24px;height:10px;margin-right:6px;border-radius:2px}
.source{font-weight:bold;text-decoration:underline}
</style></head><body>
<div id="stage"><canvas id="view"></canvas><div id="legend"></div><div id="explain"></div></div>
<div id="bar"><div id="row">
<button id="play">pause</button>
<input id="slider" type="range" min="0" max="0" value="0" step="1" aria-label="time">
<span id="readout">loading clips...</span>
<label>speed <select id="speed"><option>0.1</option><option>0.25</option><option>0.5</option>
<option selected>1</option><option>2</option></select></label>
<label><input id="overlay" type="checkbox"> overlay</label>
<label><input id="follow" type="checkbox" checked> follow root</label>
<button id="reset" title="drag: rotate, wheel: zoom, space: play/pause, arrows: step">reset view</button>
</div><canvas id="strip" height="14"></canvas></div>
<script>
"use strict";
// Per clip: centre, left and right bones, then its root path.
const PALETTES = [["#222222", "#1f6fd1", "#d1431f", "#2a9d55"], ["#3b2470", "#7b4fd8", "#e08a1e", "#b07cc6"],
  ["#0d5c4a", "#14a38b", "#c23b7a", "#5fb3a1"], ["#5c3a0d", "#b8860b", "#4169e1", "#c9a227"],
  ["#444444", "#2e8b57", "#b22222", "#999999"]];
const $ = (id) => document.getElementById(id);
const view = $("view"), ctx = view.getContext("2d"), strip = $("strip"), sctx = strip.getContext("2d");
const S = {t: 0, playing: true, speed: 1, yaw: 0.3, pitch: 0.25, zoom: 1, last: null, drag: null};
let D = null;
const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const unit = (a) => { const n = Math.hypot(a[0], a[1], a[2]) || 1; return [a[0] / n, a[1] / n, a[2] / n]; };
const clamp = (x, lo, hi) => Math.min(hi, Math.max(lo, x));
const baseName = (s) => s.split(/[\\/]/).pop();

function init(data) {
  D = data; D.duration = 0; D.maxFps = 1;
  D.clips.forEach((c, i) => {
    c.p = Float32Array.from(c.positions); delete c.positions;
    c.J = c.sides.length; c.palette = PALETTES[i % PALETTES.length];
    c.path = new Float32Array(2 * c.num_frames); c.box = [Infinity, -Infinity, Infinity, -Infinity];
    for (let f = 0; f < c.num_frames; f++) {
      const q = joint(c, f, c.pelvis); c.path[2 * f] = q[0]; c.path[2 * f + 1] = q[2];
      c.box = [Math.min(c.box[0], q[0]), Math.max(c.box[1], q[0]), Math.min(c.box[2], q[2]), Math.max(c.box[3], q[2])];
    }
    D.duration = Math.max(D.duration, (c.num_frames - 1) / c.fps); D.maxFps = Math.max(D.maxFps, c.fps);
  });
  D.totalFrames = Math.round(D.duration * D.maxFps) + 1;
  $("slider").max = D.totalFrames - 1;
  for (const [i, c] of D.clips.entries()) {
    const row = document.createElement("div"), sw = document.createElement("span"), text = document.createElement("span");
    sw.className = "swatch"; sw.style.background = `linear-gradient(90deg,${c.palette[1]},${c.palette[0]},${c.palette[2]})`;
    text.id = "clip" + i; row.append(sw, text); $("legend").append(row);
  }
  if (D.explain) $("explain").style.display = "block"; else strip.style.display = "none";
  // Page options for links and tests: ?overlay=1&follow=0&t=SECONDS&paused=1&speed=0.5
  const q = new URLSearchParams(location.search);
  if (q.has("overlay")) $("overlay").checked = q.get("overlay") === "1";
  if (q.has("follow")) $("follow").checked = q.get("follow") !== "0";
  if (q.has("t")) S.t = clamp(Number(q.get("t")) || 0, 0, D.duration);
  if (q.has("speed")) { S.speed = Number(q.get("speed")) || 1; $("speed").value = String(S.speed); }
  if (q.get("paused") === "1") setPlaying(false);
  window.addEventListener("resize", resize); resize(); draw();
  document.body.dataset.ready = "1";
  requestAnimationFrame(tick);
}
function joint(c, f, j) { const k = (f * c.J + j) * 3; return [c.p[k], c.p[k + 1], c.p[k + 2]]; }
function frameOf(c) { return Math.min(c.num_frames - 1, Math.round(S.t * c.fps)); }
function resize() {
  const r = window.devicePixelRatio || 1;
  view.width = view.clientWidth * r; view.height = view.clientHeight * r; ctx.setTransform(r, 0, 0, r, 0, 0);
  strip.width = strip.clientWidth;
}
// Lanes: side by side each clip has its own lane; overlaid, one lane holds all (their world offsets kept).
function lanes() {
  const H = D.height, overlay = $("overlay").checked, follow = $("follow").checked;
  const R = (overlay ? 1.3 : 0.75) * H, gap = 0.25 * H;
  const groups = overlay ? [D.clips.map((_, i) => i)] : D.clips.map((_, i) => [i]);
  const out = []; let x = 0;
  for (const g of groups) {
    let ax = 0, az = 0, ground = Infinity;
    for (const i of g) {
      const c = D.clips[i], q = joint(c, follow ? frameOf(c) : 0, c.pelvis);
      ax += q[0] / g.length; az += q[2] / g.length; ground = Math.min(ground, c.ground);
    }
    const ext = [-R, R, -R, R];
    if (!follow) for (const i of g) {
      const b = D.clips[i].box, m = 0.5 * H;
      ext[0] = Math.min(ext[0], b[0] - ax - m); ext[1] = Math.max(ext[1], b[1] - ax + m);
      ext[2] = Math.min(ext[2], b[2] - az - m); ext[3] = Math.max(ext[3], b[3] - az + m);
    }
    out.push({g, ax, az, ground, ext, ox: x - ext[0]}); x += ext[1] - ext[0] + gap;
  }
  const width = x - gap; for (const l of out) l.ox -= width / 2;
  return {lanes: out, width};
}
function camera(L) {
  const w = view.clientWidth, h = view.clientHeight, tanHalf = Math.tan(0.33), H = D.height;
  const fit = Math.max((0.5 * L.width + 0.4 * H) / (tanHalf * w / h), 0.85 * H / tanHalf), dist = fit * S.zoom;
  const target = [0, 0.45 * H, 0], cp = Math.cos(S.pitch);
  const eye = [dist * cp * Math.sin(S.yaw), target[1] + dist * Math.sin(S.pitch), dist * cp * Math.cos(S.yaw)];
  const fw = unit(sub(target, eye)), right = unit(cross(fw, [0, 1, 0])), up = cross(right, fw);
  return {eye, fw, right, up, f: (h / 2) / tanHalf, cx: w / 2, cy: h / 2, near: 0.02 * H};
}
function depth(C, p) { return dot(sub(p, C.eye), C.fw); }
function proj(C, p) {
  const v = sub(p, C.eye), z = Math.max(dot(v, C.fw), C.near);
  return [C.cx + C.f * dot(v, C.right) / z, C.cy - C.f * dot(v, C.up) / z];
}
function seg(C, a, b) {  // a line segment, cut at the near plane
  const za = depth(C, a), zb = depth(C, b);
  if (za < C.near && zb < C.near) return;
  const cut = (p, q, zp, zq) => {
    const s = (C.near - zp) / (zq - zp);
    return [p[0] + s * (q[0] - p[0]), p[1] + s * (q[1] - p[1]), p[2] + s * (q[2] - p[2])];
  };
  if (za < C.near) a = cut(a, b, za, zb); else if (zb < C.near) b = cut(b, a, zb, za);
  const pa = proj(C, a), pb = proj(C, b); ctx.moveTo(pa[0], pa[1]); ctx.lineTo(pb[0], pb[1]);
}
function pathLine(C, l, c, upto, colour, width) {
  ctx.strokeStyle = colour; ctx.lineWidth = width; ctx.beginPath();
  let open = false;
  for (let f = 0; f <= upto; f++) {
    const x = c.path[2 * f] - l.ax, z = c.path[2 * f + 1] - l.az, p = [x + l.ox, 0, z];
    if (x < l.ext[0] || x > l.ext[1] || z < l.ext[2] || z > l.ext[3] || depth(C, p) < C.near) { open = false; continue; }
    const q = proj(C, p);
    if (open) ctx.lineTo(q[0], q[1]); else { ctx.moveTo(q[0], q[1]); open = true; }
  }
  ctx.stroke();
}
function draw() {
  const w = view.clientWidth, h = view.clientHeight, H = D.height, s = D.grid_spacing;
  ctx.fillStyle = "#f7f7f5"; ctx.fillRect(0, 0, w, h);
  const L = lanes(), C = camera(L);
  ctx.strokeStyle = "#cfcfca"; ctx.lineWidth = 1; ctx.beginPath();
  for (const l of L.lanes) {
    const [x0, x1, z0, z1] = l.ext;
    for (let k = Math.ceil((x0 + l.ax) / s); k * s - l.ax <= x1; k++) {
      const x = k * s - l.ax + l.ox; seg(C, [x, 0, z0], [x, 0, z1]);
    }
    for (let k = Math.ceil((z0 + l.az) / s); k * s - l.az <= z1; k++) {
      const z = k * s - l.az; seg(C, [x0 + l.ox, 0, z], [x1 + l.ox, 0, z]);
    }
  }
  ctx.stroke();
  ctx.lineCap = "round"; ctx.textAlign = "center"; ctx.font = "13px system-ui,sans-serif";
  for (const l of L.lanes) for (const [n, i] of l.g.entries()) {
    const c = D.clips[i], f = frameOf(c), place = (q) => [q[0] - l.ax + l.ox, q[1] - l.ground, q[2] - l.az];
    pathLine(C, l, c, c.num_frames - 1, "rgba(0,0,0,0.12)", 1.5);
    pathLine(C, l, c, f, c.palette[3], 2);
    for (const [a, b] of c.bones) {
      ctx.strokeStyle = c.palette[c.sides[b]]; ctx.lineWidth = 3; ctx.beginPath();
      seg(C, place(joint(c, f, a)), place(joint(c, f, b))); ctx.stroke();
    }
    for (const [k, toe] of c.toes.entries()) {  // planted feet: a dot on the ground under the toe
      if (!c.contacts[f * c.toes.length + k]) continue;
      const q = place(joint(c, f, toe)); q[1] = 0;
      if (depth(C, q) > C.near) {
        const pq = proj(C, q); ctx.fillStyle = "rgba(220,40,40,0.85)";
        ctx.beginPath(); ctx.arc(pq[0], pq[1], 5, 0, 2 * Math.PI); ctx.fill();
      }
    }
    const top = place(joint(c, f, c.pelvis)); top[1] = 1.05 * H;
    if (depth(C, top) > C.near) {
      const q = proj(C, top); ctx.fillStyle = c.palette[0]; ctx.fillText(c.label, q[0], q[1] - 16 * n);
    }
    $("clip" + i).textContent = `${c.label}  frame ${f + 1}/${c.num_frames}`;
  }
  const g = Math.round(S.t * D.maxFps);
  $("readout").textContent = `t = ${S.t.toFixed(2)} s  frame ${g + 1}/${D.totalFrames}`;
  $("slider").value = g; document.body.dataset.frame = String(g);
  if (D.explain) drawExplain();
}
function currentPatch(track) {
  let now = null;
  for (const p of track.patches) { if (p.output_start_s <= S.t + 1e-9) now = p; else break; }
  return now;
}
function hue(name) { let x = 7; for (const ch of name) x = (x * 31 + ch.charCodeAt(0)) % 360; return x; }
function drawExplain() {
  const lines = [`explain: ${D.explain.source}`], sources = new Set();
  const w = strip.width, rows = D.explain.styles.length, rh = 14 / Math.max(rows, 1);
  sctx.clearRect(0, 0, w, 14);
  D.explain.styles.forEach((track, k) => {
    track.patches.forEach((p, n) => {
      const end = n + 1 < track.patches.length ? track.patches[n + 1].output_start_s : D.duration;
      sctx.fillStyle = `hsl(${hue(p.style_clip)},55%,${p.style_mirrored ? 45 : 65}%)`;
      const x0 = w * p.output_start_s / D.duration, x1 = w * end / D.duration;
      sctx.fillRect(x0, k * rh, Math.max(1, x1 - x0 - 1), rh - 1);
    });
    const p = currentPatch(track);
    if (!p) { lines.push(`style ${k + 1}: (before the first patch)`); return; }
    sources.add(baseName(p.style_clip));
    lines.push(`style ${k + 1}: ${baseName(p.style_clip)}${p.style_mirrored ? " (mirrored)" : ""}`);
    lines.push(`  frames ${p.style_start_frame}-${p.style_start_frame + p.style_frames - 1}` +
      `  stretch x${p.stretch.toFixed(2)}  similarity ${p.similarity.toFixed(3)}  from ${p.output_start_s.toFixed(2)} s`);
  });
  sctx.fillStyle = "#000"; sctx.fillRect(w * S.t / Math.max(D.duration, 1e-9) - 1, 0, 2, 14);
  $("explain").textContent = lines.join("\n");
  D.clips.forEach((c, i) => $("clip" + i).classList.toggle("source", sources.has(baseName(c.label))));
}
function advance() {
  const now = performance.now();
  if (S.last !== null && S.playing) {
    S.t += (now - S.last) / 1000 * S.speed;
    if (S.t > D.duration) S.t = D.duration > 0 ? S.t % D.duration : 0;
  }
  S.last = now; draw();
}
function tick() { advance(); requestAnimationFrame(tick); }
// Some hosts (headless, embedded) starve requestAnimationFrame: keep the clock moving on a timer too.
setInterval(() => { if (D && !document.hidden && performance.now() - S.last > 100) advance(); }, 100);
function setPlaying(on) { S.playing = on; $("play").textContent = on ? "pause" : "play"; }
function step(frames) { setPlaying(false); S.t = clamp((Math.round(S.t * D.maxFps) + frames) / D.maxFps, 0, D.duration); }
$("play").onclick = () => setPlaying(!S.playing);
$("slider").oninput = (e) => { setPlaying(false); S.t = Number(e.target.value) / D.maxFps; };
$("speed").onchange = (e) => { S.speed = Number(e.target.value); };
$("reset").onclick = () => { S.yaw = 0.3; S.pitch = 0.25; S.zoom = 1; };
view.addEventListener("pointerdown", (e) => { S.drag = [e.clientX, e.clientY]; view.setPointerCapture(e.pointerId); });
view.addEventListener("pointerup", () => { S.drag = null; });
view.addEventListener("pointermove", (e) => {
  if (!S.drag) return;
  S.yaw -= (e.clientX - S.drag[0]) * 0.008; S.pitch = clamp(S.pitch + (e.clientY - S.drag[1]) * 0.008, -0.2, 1.5);
  S.drag = [e.clientX, e.clientY];
});
view.addEventListener("wheel", (e) => {
  e.preventDefault(); S.zoom = clamp(S.zoom * Math.exp(e.deltaY * 0.001), 0.05, 20);
}, {passive: false});
window.addEventListener("keydown", (e) => {
  if (!D || ["INPUT", "SELECT", "BUTTON"].includes(e.target.tagName)) return;
  if (e.key === " ") { e.preventDefault(); setPlaying(!S.playing); }
  else if (e.key === "ArrowRight") step(1); else if (e.key === "ArrowLeft") step(-1);
});
fetch("clips.json").then((r) => r.ok ? r.json() : Promise.reject(new Error(`HTTP ${r.status}`)))
  .then(init).catch((err) => { $("readout").textContent = `cannot load clips: ${err.message}`; });
</script></body></html>
"""
