"""Without --cluster / --replicas nothing of Ray is loaded: a whole batch and a whole start of the web app (its
command line's service, the page served and closed) in a fresh interpreter leave no `ray` module behind."""
from __future__ import annotations

import subprocess
import sys

import pytest
import soundfile as sf

from _support import speech_like

SCRIPT = """
import sys
from gesturelsm.cli import main
assert main(["batch", "--audio-dir", {speech!r}, "--methods", "gesturelsm", "ddim", "--out", {out!r}, "--raters", "1",
             "--steps", "1", "--ddim-steps", "1", "--size", "128", "--checkpoints", {assets!r}]) == 0
from gesturelsm.commands.serve import build_parser, page_service
from gesturelsm.serve.config import ServiceSettings
from gesturelsm.webapp.ui import serve_locally
args = build_parser().parse_args(["--checkpoints", {assets!r}, "--workdir", {work!r}, "--no-warmup"])
service = page_service(args, ServiceSettings(checkpoints=args.checkpoints, workdir=args.workdir))
demo, url = serve_locally(service)
demo.close()
print("RAY:", sorted(m for m in sys.modules if m == "ray" or m.startswith("ray.")))
"""


@pytest.mark.slow                        # a batch and an app start in a new interpreter
def test_a_batch_and_an_app_start_import_nothing_of_ray(tiny_assets, tmp_path):
    speech = tmp_path / "speech"
    speech.mkdir()
    for i, name in enumerate(("a.wav", "b.wav")):
        sf.write(speech / name, speech_like(1.0, seed=i), 16000)
    code = SCRIPT.format(speech=str(speech), out=str(tmp_path / "study"), assets=str(tiny_assets),
                         work=str(tmp_path / "work"))
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stderr[-3000:]
    assert run.stdout.strip().splitlines()[-1] == "RAY: []"
    assert len(list((tmp_path / "study" / "key" / "motion").glob("v_*.npz"))) == 4
