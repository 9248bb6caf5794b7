"""docs/character.png: the shared VRM character (cryptovoxels.vrm) with the real BEAT2 take retargeted onto it,
three moments side by side, drawn by three.js + three-vrm in headless Chromium from the exported file.

    .venv/bin/python scripts/character_screenshot.py [--out docs/character.png] [--times 7.5 21.0 40.0]

Needs ../shared (the take and the character), the player's npm packages (cd gesturelsm/webapp/player && npm ci) and
chromium.
"""
from __future__ import annotations

import argparse
import base64
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from app.screenshot import CHROMIUM_ARGS  # noqa: E402
from gesturelsm.export.rig import export_rig_glb  # noqa: E402
from gesturelsm.motion import MotionSequence  # noqa: E402
from gesturelsm.retarget import load_character  # noqa: E402

SHARED = REPO.parent / "shared"
PLAYER = REPO / "gesturelsm" / "webapp" / "player"
DRAW = """async ([b64, times, size]) => {
  const {C, THREE} = window.G;
  const canvas = document.createElement('canvas');
  document.body.appendChild(canvas);
  const renderer = new THREE.WebGLRenderer({canvas, antialias: true, preserveDrawingBuffer: true});
  renderer.setSize(size * times.length, size);
  renderer.setScissorTest(true);
  const bytes = Uint8Array.from(atob(b64), c => c.charCodeAt(0)).buffer;
  for (let k = 0; k < times.length; k++) {
    const ch = await C.loadCharacter(bytes);
    const scene = new THREE.Scene();
    scene.background = new THREE.Color(0xf2f2ee);
    scene.add(ch.scene, new THREE.AmbientLight(0xffffff, 1.5));
    const sun = new THREE.DirectionalLight(0xffffff, 2.0);
    sun.position.set(-1, 2, -2);
    scene.add(sun);
    C.seek(ch, times[k]);
    const camera = new THREE.PerspectiveCamera(30, 1, 0.1, 20);
    const hips = C.boneWorldPosition(ch, 'hips');   // follow the character as it steps
    camera.position.set(hips[0], 1.0, hips[2] - 3.0);   // VRM 0.x characters face -z
    camera.lookAt(hips[0], 0.8, hips[2]);
    renderer.setViewport(k * size, 0, size, size);
    renderer.setScissor(k * size, 0, size, size);
    renderer.render(scene, camera);
  }
  return canvas.toDataURL('image/png');
}"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=str(REPO / "docs" / "character.png"))
    ap.add_argument("--times", type=float, nargs="+", default=[7.5, 21.0, 40.0])
    ap.add_argument("--size", type=int, default=300)
    ap.add_argument("--chromium", default="/usr/bin/chromium")
    args = ap.parse_args()
    from playwright.sync_api import sync_playwright

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        seq = MotionSequence.load(SHARED / "data" / "beat2" / "smplxflame_30" / "2_scott_0_1_1.npz")
        vrm = export_rig_glb(seq, load_character(SHARED / "assets" / "characters" / "cryptovoxels.vrm"),
                             tmp / "take.vrm")
        entry = tmp / "entry.js"
        entry.write_text(f"import * as C from {json.dumps(str(PLAYER / 'src' / 'character.js'))};\n"
                         "import * as THREE from 'three';\nwindow.G = {C, THREE};\n")
        subprocess.run([str(PLAYER / "node_modules" / ".bin" / "esbuild"), str(entry), "--bundle", "--format=iife",
                        f"--outfile={tmp / 'b.js'}"], check=True, cwd=PLAYER,
                       env={**os.environ, "NODE_PATH": str(PLAYER / "node_modules")})
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=args.chromium, args=CHROMIUM_ARGS)
            page = browser.new_page()
            page.set_content("<html><body style='margin:0'></body></html>")
            page.add_script_tag(content=(tmp / "b.js").read_text())
            url = page.evaluate(DRAW, [base64.b64encode(vrm.read_bytes()).decode(), args.times, args.size])
            browser.close()
    Path(args.out).write_bytes(base64.b64decode(url.split(",", 1)[1]))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
