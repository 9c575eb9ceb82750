"""Open a swing's Meshcat HTML replay in headless Chromium and screenshot it.

    python examples/replay_screenshot.py [--out DIR] [--chromium PATH] [--at MS,MS,...]
                                         [--html REPLAY.html]

Runs the default swing, writes ``DIR/swing.html`` (what ``bplir swing
--html`` writes) -- or takes a replay already written (``--html``, e.g.
``out/traverse/traverse.html`` of ``bplir traverse``) -- opens it in Chromium with the network blocked (the file
must carry everything it needs) at moments of the replay (default 300,
900 and 3000 ms after the page opens: early, mid-swing, captured), saves
``DIR/replay_<ms>.png`` and counts the pixels of each link's colour: the
robot was rendered when both links show.  Exit status 1 when they do not.
Chromium: Debian's ``chromium`` package (``apt-get install chromium``).
"""
from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image

from bplir_drake.analysis.swing.swing_plots import replay_swing_html
from bplir_drake.analysis.swing.swing_runner import run_swing
from bplir_drake.params import preset

#: headless Chromium without a GPU (WebGL on SwiftShader) and without network
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--enable-unsafe-swiftshader", "--use-angle=swiftshader",
         "--host-resolver-rules=MAP * ~NOTFOUND",
         "--window-size=1000,700", "--hide-scrollbars"]


def screenshot(chromium: str, html: Path, png: Path, after_ms: int) -> None:
    """Chromium's picture of ``html`` after ``after_ms`` of virtual time
    (headless Chromium now and then never finishes a page: one retry)."""
    for attempt in (1, 2):
        with tempfile.TemporaryDirectory() as profile:
            try:
                subprocess.run([chromium, *FLAGS, f"--user-data-dir={profile}",
                                f"--virtual-time-budget={after_ms}", f"--screenshot={png}",
                                html.resolve().as_uri()],
                               check=True, capture_output=True, timeout=45)
                return
            except subprocess.TimeoutExpired:
                if attempt == 2:
                    raise


def link_pixels(png: Path) -> dict[str, int]:
    """How many pixels have each link's hue (systems/plant.py: link 1 blue,
    link 2 orange; the shading varies, the hue does not); the background
    is grey and the line black."""
    r, g, b = np.moveaxis(np.asarray(Image.open(png).convert("RGB")).astype(int), 2, 0)
    return {"link1 (blue)": int(((b > r + 60) & (b > g + 40)).sum()),
            "link2 (orange)": int(((r > g + 40) & (g > b + 20) & (r > 120)).sum())}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/replay")
    ap.add_argument("--chromium", default=shutil.which("chromium") or shutil.which("chromium-browser"))
    ap.add_argument("--at", default="300,900,3000", help="moments to picture (ms after opening)")
    ap.add_argument("--html", default=None, help="picture this replay instead of a new swing's")
    args = ap.parse_args()
    if not args.chromium:
        print("replay_screenshot: no Chromium found (apt-get install chromium, or --chromium PATH)",
              file=sys.stderr)
        return 2
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.html:
        html = Path(args.html)
        print(f"{html}: {html.stat().st_size / 1e6:.1f} MB")
    else:
        result = run_swing(preset())
        html = replay_swing_html(result, out / "swing.html")
        print(f"{html}: {html.stat().st_size / 1e6:.1f} MB, swing {result.summary['outcome']} "
              f"at {result.summary['swing_time_s']:.2f} s")
    ok, pictures = True, []
    for ms in (int(m) for m in args.at.split(",")):
        png = out / f"replay_{ms}.png"
        screenshot(args.chromium, html, png, ms)
        counts = link_pixels(png)
        rendered = all(n > 200 for n in counts.values())
        ok &= rendered
        pictures.append(np.asarray(Image.open(png).convert("L"), dtype=float))
        print(f"{png}: after {ms} ms, link pixels {counts} -> "
              + ("robot rendered" if rendered else "ROBOT NOT RENDERED"))
    moved = [float(np.abs(a - b).mean()) for a, b in zip(pictures, pictures[1:])]
    print("mean pixel change between the pictures: " + ", ".join(f"{m:.2f}" for m in moved)
          + (" (the replay plays)" if all(m > 0.05 for m in moved) else " (THE REPLAY IS STILL)"))
    return 0 if ok and all(m > 0.05 for m in moved) else 1


if __name__ == "__main__":
    sys.exit(main())
