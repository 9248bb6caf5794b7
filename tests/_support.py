"""Helpers shared by tests (importable because pytest puts tests/ on sys.path)."""
from __future__ import annotations

import contextlib
import os
import shutil
import time
from pathlib import Path
from typing import Iterator, Sequence

import numpy as np

from gesturelsm.motion import MotionSequence

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("GESTURELSM_SHARED") or REPO.parent / "shared")   # the real data: ../shared beside the
BEAT2 = SHARED / "data" / "beat2"                                                # repository, never copied into it
REAL_TAKE = "2_scott_0_1_1"
VRM = SHARED / "assets" / "characters" / "cryptovoxels.vrm"                     # the shared real character


def quiet(*args, **kwargs) -> None:
    """Stands in for a progress callback (gr.Progress outside a Gradio event, a pipeline's progress)."""


def until(condition, what: str, limit: float = 60.0, every: float = 0.01) -> None:
    """Returns once `condition()` holds. `limit` seconds only bound something that never gets there, on a machine
    however loaded: then the test fails saying `what` did not happen."""
    deadline = time.monotonic() + limit
    while not condition():
        assert time.monotonic() < deadline, f"not within {limit:g} s: {what}"
        time.sleep(every)


def assert_close_rel(got, want, rel: float = 1e-5) -> None:
    """max |got - want| <= rel * max |want|: two float computations of the same quantity agree to a tolerance
    relative to the tensor's scale. Element-wise tolerances fail on elements near zero, whose rounding error is
    set by the size of the terms that cancelled there, which depends on the machine's summation order."""
    g = got.detach().cpu().double().numpy() if hasattr(got, "detach") else np.asarray(got, np.float64)
    w = want.detach().cpu().double().numpy() if hasattr(want, "detach") else np.asarray(want, np.float64)
    assert g.shape == w.shape, (g.shape, w.shape)
    err, scale = float(np.abs(g - w).max(initial=0.0)), float(np.abs(w).max(initial=0.0))
    assert err <= rel * max(scale, 1e-12), f"max abs diff {err:.3g} > {rel:g} x scale {scale:.3g}"


def assert_follows_loudness(gains: Sequence[float]) -> None:
    """Loudness-following gains (metrics.speech_response.energy_following) pooled over clips x seeds. Motion that
    ignores the speech gains 0 on average with a spread of ~0.13 per clip, so single clips say little: the mean must
    be clearly positive (> 0.08) and significant (> 2.5 standard errors). Offline and streamed use the same bar."""
    g = np.asarray(gains, np.float64)
    assert len(g) >= 8, "too few clips x seeds to pool"
    assert g.mean() > 0.08 and g.mean() > 2.5 * g.std(ddof=1) / np.sqrt(len(g)), np.round(g, 3).tolist()


def synthetic_motion(frames: int = 480, seed: int = 0) -> MotionSequence:
    """Smooth random motion: sums of slow sines per pose channel."""
    rng = np.random.default_rng(seed)
    t = np.arange(frames)[:, None] / 30
    poses = 0.3 * np.sin(2 * np.pi * rng.uniform(0.2, 1.5, (1, 165)) * t + rng.uniform(0, 6, (1, 165)))
    trans = np.tile([0.0, 1.3, 0.0], (frames, 1))
    return MotionSequence(poses, trans, 0.5 * np.sin(t * rng.uniform(0.5, 2, (1, 100))))


def speech_like(seconds: float, sr: int = 16000, seed: int = 0) -> np.ndarray:
    """Bursts of noise-modulated tones (syllable-like envelopes), deterministic."""
    rng = np.random.default_rng(seed)
    n = int(seconds * sr)
    t = np.arange(n) / sr
    env = np.clip(np.sin(2 * np.pi * 3.1 * t), 0, None) ** 2 * (rng.random(n) * 0.2 + 0.8)
    return (0.3 * env * np.sin(2 * np.pi * 180 * t * (1 + 0.1 * np.sin(2 * np.pi * 0.5 * t)))).astype(np.float32)


def joints_with_pauses(pause_frames: list[int], T: int = 600) -> np.ndarray:
    """Upper-body joints swinging with speed dips (but not stops) exactly at the given frames."""
    t = np.arange(T)
    speed = np.ones(T)
    for p in pause_frames:
        speed -= 0.6 * np.exp(-((t - p) ** 2) / (2 * 3.0 ** 2))
    pos = np.cumsum(speed) / 30.0
    joints = np.zeros((T, 55, 3))
    joints[:, :, 0] = pos[:, None] * 0.5
    return joints


def build_tiny_assets(root, steps: int = 20, batch_size: int = 8, warmup: int = 5):
    """A complete tiny checkpoint folder (4 tokenizers + 3 generators, `root/tokenizer`, `root/generator`)
    trained briefly on synthetic motion, so pipeline-level tests need neither ../shared nor assets/."""
    from pathlib import Path

    import torch

    from gesturelsm.generator.data import build_take
    from gesturelsm.generator.train import GenTrainConfig, train_generator
    from gesturelsm.motion import REGIONS, Normalizer
    from gesturelsm.motion.regions import GENERATED_REGIONS
    from gesturelsm.tokenizer import RVQVAE, preset

    root = Path(root)
    torch.manual_seed(0)
    feats = synthetic_motion().to_features()
    toks = {}
    for r in GENERATED_REGIONS:
        cols = list(REGIONS[r].columns)
        m = RVQVAE(preset("tiny", len(cols)), r, Normalizer.fit(feats[:, cols]))
        m.train()
        m(m.normalizer.normalize(feats[:256, cols])[None])  # initialise codebooks from data
        toks[r] = m.eval()
        m.save(root / "tokenizer" / f"{r}.safetensors", half=True)
    take = build_take("synthetic", feats, speech_like(len(feats) / 30), None, toks, None)
    for method in ("gesturelsm", "rectified_flow", "ddim"):
        tc = GenTrainConfig(method=method, preset="tiny", steps=steps, batch_size=batch_size, lr=2e-3,
                            warmup=warmup, eval_every=10_000, save_every=10_000)
        gen = train_generator([take], [], toks, tc, root / "runs" / f"{method}.safetensors", log=lambda *_: None)
        gen.save(root / "generator" / f"{method}.safetensors", half=True)
    return root


@contextlib.contextmanager
def served(service) -> Iterator[str]:
    """The app over `service`, served from this process (as `python -m app` serves it); yields its local URL."""
    from gesturelsm.webapp.ui import serve_locally

    demo, url = serve_locally(service)
    try:
        yield url
    finally:
        demo.close()


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on (for a server a test starts)."""
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def gradio_client(url: str):
    """A Gradio client of a served test app. Its HTTP timeout (httpx's default is 5 s) is long enough for a server
    that shares two loaded cores with another test process: the load test's twelve clients timed out under load."""
    from gradio_client import Client

    return Client(url, verbose=False, httpx_kwargs={"timeout": 120})


def shipped_service(workdir):
    """A GestureService over the shipped checkpoints for browser tests; skips, saying why, when the checkpoints or
    the in-browser player's bundle (built by scripts/setup.sh with npm) are missing."""
    import pytest

    from gesturelsm.constants import ASSETS
    from gesturelsm.serve.config import ServiceSettings
    from gesturelsm.serve.service import GestureService
    from gesturelsm.webapp.player.component import BUNDLE

    if not (ASSETS / "generator" / "gesturelsm.safetensors").exists():
        pytest.skip(f"shipped generator checkpoints not found in {ASSETS / 'generator'}")
    if not BUNDLE.exists():
        pytest.skip(f"the player bundle {BUNDLE} is not built (scripts/setup.sh builds it with npm)")
    return GestureService.from_settings(ServiceSettings(workdir=str(workdir)))


CHROMIUM = next((p for p in ("/usr/lib/chromium/chromium", "/usr/bin/chromium", shutil.which("chromium") or "")
                 if p and os.path.exists(p)), None)


@contextlib.contextmanager
def routed_page(files: dict) -> Iterator:
    """A headless Chromium page opened at http://player.test/index.html whose requests to http://player.test/PATH are
    answered from `files` ({PATH: (body bytes, content type)}; a query string is ignored)."""
    from playwright.sync_api import sync_playwright

    from app.screenshot import CHROMIUM_ARGS

    def serve(route):
        body, kind = files[route.request.url.split("player.test", 1)[1].split("?")[0]]
        route.fulfill(status=200, body=body, content_type=kind)

    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        try:
            page = browser.new_page()
            page.route("http://player.test/**", serve)
            page.goto("http://player.test/index.html")
            yield page
        finally:
            browser.close()


@contextlib.contextmanager
def player_page(url: str, player: str, extra_args: Sequence[str] = ()) -> Iterator:
    """A page of headless Chromium (Debian's; WebGL through SwiftShader) at `url`, once the in-browser player
    `player` (a CSS selector) has loaded; skips, saying why, when no chromium is installed."""
    import pytest

    if CHROMIUM is None:
        pytest.skip("chromium is not installed (apt-get install chromium libatomic1; scripts/setup.sh does it)")
    from playwright.sync_api import sync_playwright

    from app.screenshot import CHROMIUM_ARGS

    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=list(CHROMIUM_ARGS) + list(extra_args))
        try:
            page = browser.new_page(viewport={"width": 1400, "height": 1300})
            page.goto(url)
            page.wait_for_selector(f"{player}[data-ready]", timeout=60000)
            yield page
        finally:
            browser.close()


def open_page(browser, url: str):
    """A new tab on the served page at 1400x1300, the video's accordion open."""
    page = browser.new_page(viewport={"width": 1400, "height": 1300})
    page.goto(url)
    page.locator("#generate").wait_for(timeout=60000)
    if page.locator("#video-box").count() and not page.locator("#video").count():
        page.locator("#video-box").get_by_text("Video with the speech").click()      # the video's accordion
    return page


def generate_alone(page, wav) -> None:
    """Upload `wav` and click Generate for GestureLSM alone, audio only (no transcription)."""
    for name in ("DDIM", "Rectified flow"):
        box = page.locator("#methods label", has_text=name)
        if box.count() and box.locator("input").is_checked():
            box.click()
    page.locator("#auto-transcribe input[type=checkbox]").uncheck()
    page.locator("#speech input[type=file]").first.set_input_files(str(wav))
    page.locator("#speech [data-testid=download-link]").wait_for(state="attached", timeout=60000)
    page.locator("#generate").click()
