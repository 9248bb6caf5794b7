"""The authors' methods in the web app: served with `--checkpoints` pointing at imported files, offered with
their labels beside ours, generated, rendered side by side and timed through the page's API."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from _support import served, speech_like
from gesturelsm.backends import SPECS
from gesturelsm.reference.runner import FACE_NOTE
from gesturelsm.serve.config import ServiceSettings
from gesturelsm.serve.request import TIMING_COLUMNS
from gesturelsm.serve.service import GestureService


@pytest.fixture(scope="module")
def service(ckpt_dir, tmp_path_factory) -> GestureService:
    return GestureService.from_settings(ServiceSettings(checkpoints=str(ckpt_dir), max_seconds=20,
                                                        workdir=str(tmp_path_factory.mktemp("work"))))


@pytest.fixture(scope="module")
def app_url(service):
    with served(service) as url:
        yield url


def test_page_offers_the_authors_methods_with_their_labels(service):
    from gesturelsm.webapp.ui import build_demo

    cfg = build_demo(service).blocks.get_config_file()
    box = next(c for c in cfg["components"] if c["props"].get("label") == "Methods shown side by side")
    choices = dict((v, label) for label, v in box["props"]["choices"])
    assert choices["gesturelsm_authors"] == SPECS["gesturelsm_authors"].label
    assert choices["meanflow_authors"] == SPECS["meanflow_authors"].label
    assert {"gesturelsm", "rectified_flow", "ddim"} <= set(choices)          # ours stay beside theirs
    assert "generate no face" in box["props"]["info"]


def test_generate_through_the_page_api_with_the_authors_methods(app_url, tmp_path):
    """/generate with theirs and ours: one video of three bodies, a timing row per method, the face note."""
    from gradio_client import Client, handle_file

    wav = tmp_path / "speech.wav"
    sf.write(wav, speech_like(2.0, sr=22050), 22050)
    video, table, summary, files, glb = Client(app_url, verbose=False).predict(
        handle_file(str(wav)), "", None, ["gesturelsm_authors", "meanflow_authors", "gesturelsm"], 2, 1.5, 3, 20,
        True, "light", 256, False, api_name="/generate")
    assert table["headers"] == TIMING_COLUMNS
    names = [row[0] for row in table["data"]]
    assert any(SPECS["gesturelsm_authors"].label in n for n in names)
    assert any(SPECS["meanflow_authors"].label in n for n in names)
    assert any(n.startswith("GestureLSM") and "authors" not in n for n in names)
    assert FACE_NOTE in summary
    import imageio.v3 as iio

    props = iio.improps(video, plugin="pyav")
    assert props.shape[2] == 3 * props.shape[1]                               # three bodies side by side
    assert {Path(f).suffix for f in files} >= {".npz", ".bvh", ".glb"}
    motions = [np.load(f) for f in files if Path(f).suffix == ".npz"]
    assert len(motions) == 3
    poses = [m["poses"] for m in motions]
    assert not np.allclose(poses[0], poses[1])                                # the methods differ
