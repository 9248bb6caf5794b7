"""One smoke test of the app's service on the shipped checkpoints (skips when they are not in assets/)."""
from __future__ import annotations

import json

import pytest

from gesturelsm.pipeline import ASSETS
from gesturelsm.webapp.ui import EXAMPLES


@pytest.mark.slow                                    # the shipped network, then a 5 s video rendered at niceness 19
def test_shipped_checkpoints_serve_an_example(tmp_path):
    if not (ASSETS / "generator" / "gesturelsm.safetensors").exists():
        pytest.skip(f"shipped generator checkpoints not found in {ASSETS / 'generator'}")
    from gesturelsm.serve.config import ServiceSettings
    from gesturelsm.serve.request import Request
    from gesturelsm.serve.service import GestureService

    ex = json.loads((EXAMPLES / "examples.json").read_text())[0]
    service = GestureService.from_settings(ServiceSettings(workdir=str(tmp_path)))
    out = service.run(Request(str(EXAMPLES / ex["audio"]), text=ex["text"], methods=["gesturelsm"], steps=4,
                              size=256, exports=False))
    assert out.video.stat().st_size > 10_000
    assert "aligned automatically" in out.text_mode
    # the real-time factor shown is seconds of speech per second of generation (alignment and rendering excluded);
    # how fast it is depends on the machine, so the benchmarks report it, the test checks how it is computed
    t = out.timings["gesturelsm"]
    gen_s = sum(v for k, v in t.items() if k not in ("alignment", "transcription", "rendering"))
    assert out.rows[0].real_time_factor == pytest.approx(out.motions["gesturelsm"].duration / gen_s, rel=0.05, abs=0.1)
    poses = out.motions["gesturelsm"].poses
    assert poses.std(axis=0).max() > 1e-3                     # the body moves
