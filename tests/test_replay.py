"""The Meshcat HTML replay of a swing (issue 19): self-contained (every
resource inlined, nothing fetched from a network), and the recorded
animation it embeds is the logged swing -- each link's rotation in each
frame equals the logged joint angles at the frame's time."""
import base64
import math
import re
import shutil
import subprocess
import sys
from pathlib import Path

import msgpack
import numpy as np
import pytest

from bplir_drake.analysis.swing import run_swing
from bplir_drake.analysis.swing.swing_plots import replay_swing_html, swing_replay_scene
from bplir_drake.cli import main
from bplir_drake.params import preset

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def swing():
    return run_swing(preset(), seed=0)


def _commands(html: str) -> list[dict]:
    """The Meshcat commands the HTML feeds its viewer (base64 msgpack)."""
    blobs = re.findall(r'fetch\("data:application/octet-binary;base64,([A-Za-z0-9+/=]+)"\)', html)
    return [msgpack.unpackb(base64.b64decode(b), raw=False, strict_map_key=False) for b in blobs]


def test_replay_html_is_self_contained(swing, tmp_path):
    html = replay_swing_html(swing, tmp_path / "swing.html").read_text()
    # no resource the browser would load from elsewhere: scripts and the
    # scene are inlined, every fetch() reads a data: URL
    assert not re.search(r"<script[^>]*\ssrc\s*=", html, re.I)
    assert not re.search(r"<link[^>]*\shref\s*=", html, re.I)
    assert not re.search(r"""\s(?:src|href)\s*=\s*["']?(?:https?:)?//""", html, re.I)
    fetched = re.findall(r'fetch\("([^"]{0,40})', html)
    assert fetched and all(f.startswith("data:") for f in fetched)
    assert "MeshCat.Viewer" in html and len(html) > 1_000_000  # the viewer itself is inside
    assert "<title>BPLIR swing: captured (seed 0" in html


def test_replay_html_holds_the_recorded_swing(swing, tmp_path):
    fps = 30.0
    commands = _commands(replay_swing_html(swing, tmp_path / "swing.html", fps=fps).read_text())
    kinds = [c["type"] for c in commands]
    assert kinds.count("set_animation") == 1
    anim = next(c for c in commands if c["type"] == "set_animation")
    assert anim["options"]["play"] is True
    tracks = {a["path"]: {t["name"]: t["keys"] for t in a["clip"]["tracks"]}
              for a in anim["animations"]}
    st = swing.logs["state"]
    t_end = st.t[-1] - st.t[0]
    for link, angle in (("link1", st.data[:, 0]), ("link2", st.data[:, 0] + st.data[:, 1])):
        keys = tracks[f"/drake/robot/{link}"][".quaternion"]
        assert len(keys) == math.floor(t_end * fps + 0.5) + 1  # every frame of the swing
        for key in keys:
            # three.js quaternion (x, y, z, w) of a rotation about the plane's normal
            want = np.interp(key["time"] / fps, st.t - st.t[0], angle)
            x, y, z, w = key["value"]
            assert abs(x) < 1e-9 and abs(y) < 1e-9
            got = 2 * math.atan2(z, w)
            assert abs(math.remainder(got - want, 2 * math.tau / 2)) < 1e-6
    # the line, the target and the grippers' clamps are in the scene; the
    # arriving gripper's clamp appears at the capture (seed 0 captures at
    # 1.3355 s, after the last frame at 1.3333 s: it shows on that frame)
    objects = {c["path"] for c in commands if c["type"] == "set_object"}
    assert {"/drake/scene/line/0", "/drake/scene/targets/0", "/drake/scene/clamps/0",
            "/drake/scene/clamps/1"} <= objects
    shown = tracks["/drake/scene/clamps/1"][".visible"]
    assert [k["value"] for k in shown] == [False, True]
    assert shown[1]["time"] == pytest.approx(swing.summary["swing_time_s"] * fps, abs=1)
    scene = swing_replay_scene(swing)
    assert scene.targets[0] == pytest.approx((swing.params.scenario.grip_spacing, 0.0))


def test_cli_swing_html(tmp_path, capsys):
    assert main(["swing", "--html", "--no-animation", "--out", str(tmp_path), "--json"]) == 0
    import json

    out = json.loads(capsys.readouterr().out)
    assert Path(out["files"]["replay_html"]) == tmp_path / "swing.html"
    assert _commands((tmp_path / "swing.html").read_text())


@pytest.mark.skipif(shutil.which("chromium") is None, reason="Debian chromium not installed")
def test_replay_renders_in_headless_chromium(tmp_path):
    """The example script: the robot's links show in Chromium's pictures
    of the replay (network blocked) and the pictures change (it plays)."""
    run = subprocess.run([sys.executable, str(ROOT / "examples" / "replay_screenshot.py"),
                          "--out", str(tmp_path), "--at", "300,1200"],
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stdout + run.stderr
    assert run.stdout.count("robot rendered") == 2 and "(the replay plays)" in run.stdout
