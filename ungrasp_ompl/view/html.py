"""The view as one self-contained HTML page: meshcat's viewer with the scene and its animation.

The scene is built with meshcat's own geometry, command and animation classes (meshcat-python)
and packed the way its websocket server sends them (msgpack); the page embeds them with meshcat's
viewer script (three.js, ``main.min.js`` from the meshcat package), so it needs no server and
downloads nothing when it opens. Around the viewer the page adds play/pause, a time slider, the
running phase's name (each primitive while it runs), a legend and two viewpoints.

URL query (for links and for screenshots): ``?t=SECONDS`` opens paused at that time;
``camera=overview|close`` picks the viewpoint; ``hud=0`` hides the overlays.
"""

from __future__ import annotations

import base64
import json
import os
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..io import write_text_atomic
from .scene import ViewScene

ROOT = "/ungrasp"
BACKGROUND = ((0.97, 0.97, 0.98), (0.80, 0.84, 0.90))  # top, bottom colours of the gradient


def viewer_script() -> str:
    """meshcat's viewer (three.js and its scene handling), shipped in the meshcat package."""
    import meshcat  # meshcat: loaded to write a page, not to read a record

    return (Path(meshcat.viewer_assets_path()) / "dist" / "main.min.js").read_text(encoding="utf-8")


def _rgb_int(rgba: tuple[float, ...]) -> int:
    r, g, b = (int(round(255 * min(max(c, 0.0), 1.0))) for c in rgba[:3])
    return (r << 16) | (g << 8) | b


def _quaternions(rot: NDArray) -> NDArray[np.float64]:
    """three.js quaternions (x, y, z, w) of rotations (F, 3, 3), sign-continuous along F."""
    from scipy.spatial.transform import Rotation  # scipy.spatial: 0.4 s, loaded to write a page

    quat = Rotation.from_matrix(rot).as_quat()  # scalar last: x, y, z, w
    for i in range(1, len(quat)):
        if np.dot(quat[i], quat[i - 1]) < 0:
            quat[i] = -quat[i]
    return quat


def _changes(values: NDArray, tol: float = 1e-7) -> NDArray[np.int64]:
    """Indices of key frames that linear interpolation needs: where the value moves, and the ends."""
    n = len(values)
    if n <= 2:
        return np.arange(n)
    step = np.max(np.abs(np.diff(values.reshape(n, -1).astype(float), axis=0)), axis=1) > tol
    keep = np.zeros(n, dtype=bool)
    keep[0] = keep[-1] = True
    keep[1:] |= step  # the frame after a move
    keep[:-1] |= step  # the frame before it
    return np.flatnonzero(keep)


def commands(scene: ViewScene) -> list[bytes]:
    """The meshcat commands (msgpack, as meshcat's server sends them) that build and animate scene."""
    import meshcat.animation as mca  # meshcat, as in viewer_script
    import meshcat.commands as mcc
    import meshcat.geometry as mcg
    import umsgpack
    from meshcat.path import Path as MPath

    def path(p: str) -> MPath:
        return MPath(tuple(x for x in f"{ROOT}/{p}".split("/") if x))

    def pack(cmd) -> bytes:
        return umsgpack.packb(cmd.lower(), force_float_precision="single")

    out = [pack(mcc.SetProperty("visible", False, MPath(("Grid",)))),
           pack(mcc.SetProperty("visible", False, MPath(("Axes",)))),
           pack(mcc.SetProperty("top_color", list(BACKGROUND[0]), MPath(("Background",)))),
           pack(mcc.SetProperty("bottom_color", list(BACKGROUND[1]), MPath(("Background",))))]
    anim = mca.Animation(default_framerate=1)  # one "frame" per second: key times are in seconds
    for b, body in enumerate(scene.bodies):
        material = mcg.MeshLambertMaterial(color=_rgb_int(body.rgba), opacity=float(body.rgba[3]),
                                           transparent=body.rgba[3] < 1.0, depthWrite=body.rgba[3] >= 1.0)
        mesh = mcg.TriangularMeshGeometry(body.mesh.vertices, body.mesh.faces)
        out.append(pack(mcc.SetObject(mesh, material, path(body.path))))
        poses, shown = scene.poses[b], scene.visible[b]
        out.append(pack(mcc.SetTransform(poses[0], path(body.path))))
        if np.allclose(poses, poses[0], atol=1e-9) and shown.all():
            continue  # fixed
        clip = mca.AnimationClip(fps=1)
        anim.clips[path(body.path)] = clip
        pos, quat = poses[:, :3, 3], _quaternions(poses[:, :3, :3])
        for i in _changes(pos):
            clip.set_property(float(scene.times[i]), "position", "vector3", pos[i].tolist())
        for i in _changes(quat):
            clip.set_property(float(scene.times[i]), "quaternion", "quaternion", quat[i].tolist())
        if not shown.all():  # every track has keys at 0 and at the end: the clips loop and seek together
            flips = np.flatnonzero(np.diff(shown.astype(int))) + 1
            for i in [0, *flips.tolist()]:
                clip.set_property(float(scene.times[i]), "visible", "boolean", bool(shown[i]))
            clip.set_property(float(scene.times[-1]), "visible", "boolean", bool(shown[-1]))
    out.append(pack(mcc.SetAnimation(anim, play=True, repetitions=1)))
    return out


def _meta(scene: ViewScene) -> dict:
    """What the page's controls need: duration, phases, viewpoints (world, m), legend, notes, and
    the groups a check box shows or hides (a simulated trial's planned and simulated object)."""

    def camera(c) -> dict:
        return {"target": c.target.tolist(), "position": c.position.tolist()}

    simulated = any(b.group == "simulated" for b in scene.bodies)

    def css(rgba) -> str:
        return f"rgba({int(255 * rgba[0])},{int(255 * rgba[1])},{int(255 * rgba[2])},{max(rgba[3], 0.5):.2f})"

    return {"title": scene.title, "duration": scene.duration,
            "phases": [{"name": n, "label": lab, "start": a, "end": b} for n, lab, a, b in scene.phases],
            "cameras": {k: camera(c) for k, c in scene.cameras.items()},
            "legend": [{"label": lab, "colour": css(c)} for lab, c in scene.legend], "notes": scene.notes,
            "toggles": [{"label": f"{g} object", "path": [ROOT.strip("/"), g]}
                        for g in ("planned", "simulated") if simulated]}


def page(scene: ViewScene) -> str:
    """The HTML text of the view page."""
    blobs = ",\n".join(f'"{base64.b64encode(c).decode("ascii")}"' for c in commands(scene))
    meta = json.dumps(_meta(scene)).replace("</", "<\\/")
    title = scene.title.replace("&", "&amp;").replace("<", "&lt;")
    return (_TEMPLATE.replace("@TITLE@", title).replace("@VIEWER@", viewer_script())
            .replace("@COMMANDS@", blobs).replace("@META@", meta))


def write_page(scene: ViewScene, path: str | os.PathLike[str]) -> None:
    """Write the view page to path atomically."""
    write_text_atomic(path, page(scene))


_TEMPLATE = """<!DOCTYPE html>
<html>
<head>
<meta charset="utf-8">
<title>ungrasp-ompl view: @TITLE@</title>
<style>
  body { margin: 0; font-family: sans-serif; overflow: hidden; }
  #meshcat-pane { width: 100vw; height: 100vh; overflow: hidden; }
  .hud { position: absolute; background: rgba(255,255,255,0.85); border-radius: 6px; padding: 6px 10px;
         color: #222; font-size: 14px; }
  #phase { left: 10px; top: 10px; font-size: 18px; font-weight: bold; max-width: 70vw; }
  #notes { font-size: 13px; font-weight: normal; margin-top: 2px; }
  #legend { left: 10px; bottom: 56px; font-size: 13px; line-height: 1.5; }
  #legend span.swatch { display: inline-block; width: 12px; height: 12px; margin-right: 6px;
                        vertical-align: -1px; border: 1px solid #555; }
  #bar { left: 10px; right: 10px; bottom: 10px; display: flex; align-items: center; gap: 10px; }
  #bar input[type=range] { flex: 1; }
  #bar button { font-size: 14px; min-width: 5.5em; }
  #time { font-variant-numeric: tabular-nums; min-width: 9em; text-align: right; }
</style>
</head>
<body>
<div id="meshcat-pane"></div>
<div id="phase" class="hud"><div id="phase-text"></div><div id="notes"></div></div>
<div id="legend" class="hud"></div>
<div id="bar" class="hud">
  <button id="play" type="button">Pause</button>
  <input id="slider" type="range" min="0" step="0.001" value="0">
  <span id="time"></span>
  <span id="toggles"></span>
  <button id="cam-overview" type="button">Overview</button>
  <button id="cam-close" type="button">Close-up</button>
</div>
<script>
@VIEWER@
</script>
<script>
var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
(function () {
  var blobs = [
@COMMANDS@
  ];
  for (var i = 0; i < blobs.length; i++) {
    var raw = atob(blobs[i]), bytes = new Uint8Array(raw.length);
    for (var k = 0; k < raw.length; k++) bytes[k] = raw.charCodeAt(k);
    viewer.handle_command_bytearray(bytes);
  }
})();
var META = @META@;
(function () {
  var anim = viewer.animator;
  var slider = document.getElementById("slider"), play = document.getElementById("play");
  var timeText = document.getElementById("time"), phaseText = document.getElementById("phase-text");
  var params = new URLSearchParams(window.location.search);
  slider.max = META.duration;
  document.getElementById("notes").textContent = META.notes.join("; ");
  var legend = document.getElementById("legend");
  META.legend.forEach(function (e) {
    var row = document.createElement("div"), sw = document.createElement("span");
    sw.className = "swatch"; sw.style.background = e.colour;
    row.appendChild(sw); row.appendChild(document.createTextNode(e.label)); legend.appendChild(row);
  });
  META.toggles.forEach(function (e) {  // show or hide the planned and the simulated object
    var box = document.createElement("input"), label = document.createElement("label");
    box.type = "checkbox"; box.checked = true;
    box.addEventListener("change", function () { viewer.set_property(e.path, "visible", box.checked); viewer.set_dirty(); });
    label.appendChild(box); label.appendChild(document.createTextNode(e.label + " "));
    document.getElementById("toggles").appendChild(label);
  });
  function now() {
    return anim.actions.length ? Math.min(Math.max(anim.actions[0].time, 0), META.duration) : 0;
  }
  function phaseAt(t) {
    for (var i = 0; i < META.phases.length; i++) if (t <= META.phases[i].end + 1e-9) return META.phases[i];
    return META.phases[META.phases.length - 1];
  }
  function seek(t) { anim.seek(Math.min(Math.max(t, 0), META.duration)); show(); }
  function setCamera(name) {
    // meshcat turns its scene -90 deg about x (three.js is y up) and its camera back: the camera
    // and the orbit's target live in three.js world coordinates, (x, y, z) of the scene -> (x, z, -y)
    var c = META.cameras[name];
    if (!c) return;
    viewer.camera.position.set(c.position[0], c.position[2], -c.position[1]);
    viewer.controls.target.set(c.target[0], c.target[2], -c.target[1]);
    viewer.controls.update();
    viewer.set_dirty();
  }
  var dragging = false;
  function show() {
    var t = now();
    if (!dragging) slider.value = t;
    timeText.textContent = t.toFixed(2) + " / " + META.duration.toFixed(2) + " s";
    phaseText.textContent = phaseAt(t).label;
    play.textContent = anim.playing ? "Pause" : "Play";
  }
  function loop() { show(); requestAnimationFrame(loop); }
  play.addEventListener("click", function () {
    if (anim.playing) { anim.pause(); }
    else { if (now() >= META.duration - 1e-3) seek(0); anim.play(); }
    show();
  });
  slider.addEventListener("input", function () { dragging = true; seek(parseFloat(slider.value)); });
  slider.addEventListener("change", function () { dragging = false; });
  document.getElementById("cam-overview").addEventListener("click", function () { setCamera("overview"); });
  document.getElementById("cam-close").addEventListener("click", function () { setCamera("close"); });
  setCamera(params.get("camera") || "overview");
  if (params.has("t")) { anim.pause(); seek(parseFloat(params.get("t")) || 0); }
  if (params.get("hud") === "0") {
    Array.prototype.forEach.call(document.querySelectorAll(".hud"), function (e) { e.style.display = "none"; });
  }
  show();
  loop();
  document.body.setAttribute("data-view-ready", "1");
})();
</script>
</body>
</html>
"""
