"""constants.py: the shipped assets are found both in a checkout and in an installed (non-editable) wheel."""
from __future__ import annotations

import filecmp
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from gesturelsm import constants, pipeline
from gesturelsm.body import mannequin

REPO = Path(__file__).resolve().parents[1]
# every checkpoint the package loads by default, relative to the assets folder
SHIPPED = sorted(p.relative_to(REPO / "assets").as_posix() for pattern in
                 ("tokenizer/*.safetensors", "generator/*.safetensors", "body/SMPLX_MANNEQUIN.npz")
                 for p in (REPO / "assets").glob(pattern))

# run in a fresh interpreter from the installed copy: where everything points, and the shipped pipeline loads
PROBE = """
import json, sys
import gesturelsm, gesturelsm.constants as c, gesturelsm.pipeline as p
from gesturelsm.body import mannequin
pipe = p.GesturePipeline.from_pretrained(warm_up=False)
print(json.dumps({"package": gesturelsm.__file__, "assets": str(c.ASSETS), "pipeline": str(p.ASSETS),
                  "body": str(mannequin.DEFAULT_PATH), "methods": pipe.methods}))
"""


def test_a_checkout_uses_the_repository_assets_folder():
    assert constants.ASSETS == REPO / "assets"
    assert pipeline.ASSETS == constants.ASSETS
    assert mannequin.DEFAULT_PATH == constants.ASSETS / "body" / "SMPLX_MANNEQUIN.npz"


@pytest.mark.slow                       # a whole command in subprocesses: the full tier
@pytest.mark.skipif(not SHIPPED, reason="no shipped checkpoints in assets/")
def test_an_installed_wheel_carries_and_finds_the_shipped_assets(built_wheel, tmp_path):
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check", "-q"]
    site = tmp_path / "site"
    subprocess.run(pip + ["install", "--no-deps", "--no-index", "--target", str(site), str(built_wheel)], check=True,
                   capture_output=True)

    env = {**os.environ, "PYTHONPATH": str(site)}
    run = subprocess.run([sys.executable, "-c", PROBE], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-2000:]
    got = json.loads(run.stdout.strip().splitlines()[-1])
    assets = Path(got["assets"])
    assert Path(got["package"]).is_relative_to(site), got["package"]
    assert assets.is_relative_to(site) and Path(got["pipeline"]) == assets, got
    assert Path(got["body"]) == assets / "body" / "SMPLX_MANNEQUIN.npz"
    assert set(got["methods"]) == {Path(p).stem for p in SHIPPED if p.startswith("generator/")}
    for rel in SHIPPED + ["MODEL_CARD.md"]:
        assert (assets / rel).is_file(), f"{rel} is not in the wheel"
        assert filecmp.cmp(assets / rel, REPO / "assets" / rel, shallow=False), f"{rel} differs from the repository's"
