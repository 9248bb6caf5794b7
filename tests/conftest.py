"""Shared fixtures. Real BEAT2 data lives in ../shared beside the repository (never copied into it)."""
from __future__ import annotations

import atexit
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

os.environ["GRADIO_ANALYTICS_ENABLED"] = "False"      # no telemetry from the apps the tests build
os.environ["HF_HUB_DISABLE_TELEMETRY"] = "1"
# Each test process its own Gradio cache (read when gradio is imported, so before any test imports it): Gradio names
# an upload's copy by its content and a closing demo deletes the copies it made, so a demo closed in one test process
# could delete the same speech's copy that another process's app was about to read. pytest-xdist's workers inherit
# the first process's environment: a directory made by another process (GESTURELSM_TEST_GRADIO_PID) is replaced; one
# the user set is kept.
_PID = str(os.getpid())
if "GRADIO_TEMP_DIR" not in os.environ or os.environ.get("GESTURELSM_TEST_GRADIO_PID", _PID) != _PID:
    os.environ["GRADIO_TEMP_DIR"] = tempfile.mkdtemp(prefix="gesturelsm-tests-gradio-")
    os.environ["GESTURELSM_TEST_GRADIO_PID"] = _PID
    atexit.register(shutil.rmtree, os.environ["GRADIO_TEMP_DIR"], True)

# Kernel choices are forced in tests, never measured (gesturelsm/kernels/choice.py): every fast path is taken where
# it is available, so results do not depend on this machine's timings and every path is exercised; the choice file
# stays in memory, so no test writes the user's cache. Subprocesses inherit both; a test that measures sets its own.
os.environ.setdefault("GESTURELSM_KERNELS", "all")
os.environ.setdefault("GESTURELSM_KERNELS_CACHE", "")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from _support import BEAT2, REAL_TAKE, REPO, build_tiny_assets  # noqa: E402


@pytest.fixture(scope="session")
def beat2_root() -> Path:
    if not (BEAT2 / "smplxflame_30" / f"{REAL_TAKE}.npz").exists():
        pytest.skip(f"real BEAT2 sample not found at {BEAT2} (../shared beside the repo)")
    return BEAT2


@pytest.fixture(scope="session")
def body():
    """The built-in mannequin (the body every test draws, exports and retargets on unless it says otherwise)."""
    from gesturelsm.body import resolve_body

    return resolve_body(None)


@pytest.fixture(scope="session")
def espeak() -> None:
    """eSpeak NG (the aligner's synthesiser and the speech the recognition tests make), or the test is skipped."""
    from gesturelsm.align import tts

    if not tts.available():
        pytest.skip("eSpeak NG is not installed (apt-get install espeak-ng)")


@pytest.fixture(scope="session")
def real_motion(beat2_root: Path):
    from gesturelsm.motion import MotionSequence

    return MotionSequence.load(beat2_root / "smplxflame_30" / f"{REAL_TAKE}.npz")


TEXTGRID = '''File type = "ooTextFile"
Object class = "TextGrid"

xmin = 0
xmax = {dur}
tiers? <exists>
size = 1
item []:
    item [1]:
        class = "IntervalTier"
        name = "words"
        xmin = 0
        xmax = {dur}
        intervals: size = 3
        intervals [1]:
            xmin = 0
            xmax = 0.5
            text = ""
        intervals [2]:
            xmin = 0.5
            xmax = 1.0
            text = "hello"
        intervals [3]:
            xmin = 1.0
            xmax = {dur}
            text = "world"
'''


def make_take(root: Path, name: str, frames: int, sr: int = 16000, dtype: str = "float32",
              audio_extra_s: float = 0.5, textgrid: bool = True):
    """A synthetic take: random poses, a 220 Hz tone, and a two-word TextGrid."""
    import soundfile as sf

    from gesturelsm.motion import MotionSequence

    rng = np.random.default_rng(frames)
    seq = MotionSequence(rng.normal(scale=0.3, size=(frames, 165)), np.tile([0, 1.3, 0], (frames, 1)),
                         rng.normal(size=(frames, 100)))
    seq.save(root / "smplxflame_30" / f"{name}.npz")
    n = int((frames / 30 + audio_extra_s) * sr)
    y = (0.3 * np.sin(np.arange(n) / sr * 2 * np.pi * 220)).astype(np.float32)
    (root / "wave16k").mkdir(parents=True, exist_ok=True)
    if dtype == "int16":
        sf.write(root / "wave16k" / f"{name}.wav", (y * 32767).astype(np.int16), sr, subtype="PCM_16")
    else:
        sf.write(root / "wave16k" / f"{name}.wav", y, sr, subtype="FLOAT")
    if textgrid:
        (root / "textgrid").mkdir(parents=True, exist_ok=True)
        (root / "textgrid" / f"{name}.TextGrid").write_text(TEXTGRID.format(dur=frames / 30))
    return seq


@pytest.fixture
def beat2_maker():
    """make(root, name, frames, ...) writes one synthetic take in BEAT2 layout (see make_take)."""
    return make_take


def pytest_configure(config):
    """One math thread per test process, and for the processes tests start (they inherit OMP_NUM_THREADS): the
    tests' tensors are small, so a second thread gains little, while on a 2-core machine shared with other busy
    processes OpenMP threads spinning for a busy core made a test 9x slower (tests/flows/test_methods.py's toy
    distribution: 69 s with two threads, 7.5 s with one, run one after the other). A value set outside is kept."""
    import torch

    os.environ.setdefault("OMP_NUM_THREADS", "1")
    torch.set_num_threads(int(os.environ["OMP_NUM_THREADS"]))
    # `--dist loadgroup` hands out groups in the order the workers collected them (pytest_collection_modifyitems puts
    # the heavy ones first), not sorted by their number of tests, which sent groups of a few long tests (the shipped
    # network's) last, to one worker while the other had nothing left to do.
    if getattr(config.option, "dist", None) == "loadgroup" and hasattr(config.option, "loadscopereorder"):
        config.option.loadscopereorder = False


def once_per_run(tmp_path_factory, name: str, build) -> Path:
    """`build(folder)` fills a new folder once per test run; its folder. Alone: in this process's temporary folder.
    With pytest-xdist the first worker to ask builds it in the run's temporary folder (above every worker's own)
    under a file lock and the others wait for it and read the same files, so two workers never build the same
    read-only thing twice on the 2 cores."""
    if not os.environ.get("PYTEST_XDIST_WORKER"):
        folder = tmp_path_factory.mktemp(name)
        build(folder)
        return folder
    from filelock import FileLock

    shared = tmp_path_factory.getbasetemp().parent
    done = shared / name
    with FileLock(str(shared / f"{name}.lock")):
        if not done.is_dir():
            part = Path(tempfile.mkdtemp(prefix=f"{name}-", dir=shared))
            build(part)
            part.rename(done)                            # whole or absent: a failed build leaves no folder behind
    return done


# A tiny but complete set of checkpoints (4 tokenizers + 3 generators) built from synthetic motion, so the whole
# pipeline runs in tests without ../shared or the shipped assets. Built once per test run (once_per_run; seeded, so
# every worker built the same checkpoints before, ~20 s of a busy core each) and shared by every test that needs
# checkpoints (pipeline, app, study, evaluation): tests only read it.
@pytest.fixture(scope="session")
def tiny_assets(tmp_path_factory) -> Path:
    return once_per_run(tmp_path_factory, "tiny-assets",
                        lambda root: build_tiny_assets(root, steps=20, batch_size=8, warmup=5))


@pytest.fixture(scope="session")
def tiny_pipeline(tiny_assets):
    from gesturelsm.pipeline import GesturePipeline

    return GesturePipeline.from_pretrained(tiny_assets)


# The web app's tests: a GestureService over the tiny checkpoints with a BEAT2 folder to find ground truth in,
# speech to send it, and the app served in this process on a free local port.
@pytest.fixture(scope="session")
def beat2_dir(tmp_path_factory) -> Path:
    """A BEAT2-layout folder with one 2 s take (motion, a tone as speech, TextGrid)."""
    import soundfile as sf

    from gesturelsm.motion import MotionSequence

    from _support import speech_like, synthetic_motion

    root = tmp_path_factory.mktemp("beat2")
    synthetic_motion(frames=60, seed=3).save(root / "smplxflame_30" / "2_scott_0_9_9.npz")
    (root / "wave16k").mkdir()
    sf.write(root / "wave16k" / "2_scott_0_9_9.wav", speech_like(2.0, seed=5)[::-1].copy(), 16000)
    assert isinstance(MotionSequence.load(root / "smplxflame_30" / "2_scott_0_9_9.npz"), MotionSequence)
    return root


@pytest.fixture(scope="session")
def service(tiny_assets, beat2_dir, tmp_path_factory):
    from gesturelsm.serve.config import ServiceSettings
    from gesturelsm.serve.service import GestureService

    settings = ServiceSettings(checkpoints=str(tiny_assets), beat2=str(beat2_dir), max_seconds=20,
                               workdir=str(tmp_path_factory.mktemp("app_work")))
    return GestureService.from_settings(settings)


@pytest.fixture(scope="session")
def speech_wav(tmp_path_factory) -> Path:
    """2 s of speech-like sound as a 44.1 kHz stereo wav (the app resamples)."""
    import soundfile as sf

    from _support import speech_like

    y = speech_like(2.0, sr=44100)
    path = tmp_path_factory.mktemp("speech") / "speech.wav"
    sf.write(path, np.stack([y, y], 1), 44100)
    return path


@pytest.fixture(scope="session")
def app_url(service):
    """The app served from this process (as `python -m app` serves it) at a local URL."""
    from _support import served

    with served(service) as url:
        yield url


@pytest.fixture(scope="session")
def shipped_pipe():
    """The shipped GestureLSM generator (assets/) for live-mode tests: the streaming logic is checked on the real
    network."""
    import torch

    from gesturelsm.features.audio import audio_channels
    from gesturelsm.pipeline import ASSETS, GesturePipeline

    if not (ASSETS / "generator" / "gesturelsm.safetensors").exists():
        pytest.skip("shipped checkpoints not found in assets/")
    torch.set_num_threads(1)
    pipe = GesturePipeline.from_pretrained(methods=["gesturelsm"], warm_up=False)
    audio_channels(np.random.default_rng(0).normal(scale=0.1, size=16000).astype(np.float32))  # librosa's JIT, once
    return pipe


# The wheel `pip wheel` builds from a copy of the checkout's packaging inputs (so the checkout gets no build/ or
# egg-info folders), once per test run (once_per_run): tests/test_packaging.py reads it, tests/test_constants.py
# installs it.
@pytest.fixture(scope="session")
def built_wheel(tmp_path_factory) -> Path:
    def build(out: Path) -> None:
        src = Path(tempfile.mkdtemp(prefix="wheel-src-", dir=out.parent))
        for name in ("setup.py", "pyproject.toml", "README.md"):
            shutil.copy2(REPO / name, src / name)
        ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "node_modules", "*.egg-info")
        for name in ("gesturelsm", "assets"):
            shutil.copytree(REPO / name, src / name, ignore=ignore)
        subprocess.run([sys.executable, "-m", "pip", "--disable-pip-version-check", "wheel", "--no-deps",
                        "--no-build-isolation", "--no-index", "-q", "-w", str(out), str(src)],
                       check=True, cwd=src, capture_output=True)
        shutil.rmtree(src)                      # nothing to fall back on but what the wheel carries

    (found,) = once_per_run(tmp_path_factory, "wheel", build).glob("gesturelsm-*.whl")
    return found


# Fixtures whose tests leave the fast tier (`make test-fast`, `-m "not slow and not browser"`): each costs tens of
# seconds on 2 cores or reads the real data; `make test` runs them all. Tests that need the shipped network or a real
# model load (Whisper, the text encoder in a new interpreter) are marked slow where they are defined.
HEAVY_FIXTURES = {
    "app_url": "serves the web app",
    "service": "the web app's request service over trained checkpoints (renders videos)",
    "shipped_pipe": "streams through the shipped network",
    "recognizer": "loads Whisper",
    "beat2_root": "reads the real BEAT2 take",
    "beat2": "reads the real BEAT2 take",
    "eval_assets": "runs the evaluation runners (eval, bench, sweep) over checkpoints",
    "ray_cluster": "starts a Ray cluster of two one-CPU nodes on this machine",
}


# `--dist loadgroup` schedules by the group that pytest-xdist appends to each test's node id ("...::test@group").
# pytest-xdist 3.8 writes it to `item._nodeid`, which pytest 9.2's structured node ids no longer read
# (pytest-dev/pytest-xdist#1386), so no group reached the scheduler: a module's tests were spread over both workers
# (module fixtures built twice), both workers drove Chromium at once and each started its own Ray cluster. With
# structured ids (`item._id`) the group is appended here; tryfirst so that older pytest, where xdist's own hook
# works, finds the markers in place when it runs.
@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    parallel = config.pluginmanager.hasplugin("xdist")
    for item in items:
        if HEAVY_FIXTURES.keys() & set(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.slow)
        if parallel:
            # With `-n 2 --dist loadgroup` (the Makefile's): a module's tests stay in one process, so its module
            # fixtures are built once; the browser tests share one process, so two Chromiums never compete for
            # the 2 cores with a served app and a render each.
            # The Ray cluster tests share one process too: two simulated clusters at once would not fit 2 cores.
            group = ("browser" if item.get_closest_marker("browser") else
                     "ray" if "ray_cluster" in getattr(item, "fixturenames", ()) else item.nodeid.split("::")[0])
            item.add_marker(pytest.mark.xdist_group(group))
    if parallel and os.environ.get("PYTEST_XDIST_WORKER") and config.getvalue("loadgroup"):
        heavy_first(items)
        for item in items:
            if hasattr(item, "_id") and "@" not in item.nodeid.rpartition("]")[2]:
                from _pytest.nodeid import NodeId

                item._id = NodeId.parse(f"{item.nodeid}@{item.get_closest_marker('xdist_group').args[0]}")


def heavy_first(items) -> None:
    """Reorder the collection by group, the heaviest groups first (tests keep their order inside a group), so that
    with two workers the long groups start early and the short ones fill in at the end (longest first is the classic
    rule for balancing jobs over machines; a group of one long test handed out last kept one worker busy alone). A
    group's weight, in rough seconds: its test count plus SLOW_WEIGHT per test marked slow or browser, or what
    MEASURED_SECONDS says if that is more."""
    def group(item) -> str:
        return item.get_closest_marker("xdist_group").args[0]

    weight: dict[str, float] = dict(MEASURED_SECONDS)
    counted: dict[str, int] = {}
    for item in items:
        heavy = item.get_closest_marker("slow") or item.get_closest_marker("browser")
        counted[group(item)] = counted.get(group(item), 0) + (SLOW_WEIGHT if heavy else 1)
    for g, w in counted.items():
        weight[g] = max(weight.get(g, 0), w)
    order = {g: i for i, g in enumerate(dict.fromkeys(group(item) for item in items))}
    items.sort(key=lambda item: (-weight[group(item)], order[group(item)]))


SLOW_WEIGHT = 20
# The groups whose longest tests took over 100 s together in one `make test` (--durations=60) on the 2-core machine
# shared with other work: the figures are high (the videos render at nice 19 and waited for the other
# work), and only set the order in which groups are handed out.
MEASURED_SECONDS = {
    "tests/serve/test_service.py": 1398, "tests/reference/test_reference_app.py": 1254, "ray": 720,
    "tests/live/test_stream.py": 617, "browser": 487, "tests/serve/test_hardening.py": 455,
    "tests/serve/test_shipped.py": 359, "tests/render/test_background.py": 262, "tests/webapp/test_api_schema.py": 212,
    "tests/generator/test_shipped.py": 178, "tests/serve/test_app_process.py": 158,
    "tests/generator/test_training.py": 153, "tests/webapp/test_handlers.py": 114,
}


@pytest.fixture
def hears_hello(monkeypatch):
    """Automatic transcription that hears "hello there" in any speech."""
    from types import SimpleNamespace

    import gesturelsm.pipeline as pipeline
    from gesturelsm.align import Word
    from gesturelsm.asr.source import AutomaticWords

    def hear(audio, remember=True, language="auto", on_piece=None):
        return AutomaticWords([Word("hello", 0.3, 0.7), Word("there", 0.8, 1.3)], "automatic transcript (2 words "
                              "recognised, confidence 0.90, word timings: test)", SimpleNamespace(text="hello there"))
    monkeypatch.setattr(pipeline, "automatic_words", hear)


@pytest.fixture
def measuring(monkeypatch, tmp_path):
    """Kernel choices measured (not forced), with the default measuring budget, cached in a fresh file; nothing a
    test decides outlives it (tests/test_kernels_choice.py, tests/test_kernels_first_run.py)."""
    from gesturelsm.kernels import choice

    monkeypatch.setenv("GESTURELSM_KERNELS", "measure")
    monkeypatch.setenv("GESTURELSM_KERNELS_CACHE", str(tmp_path / "kernels.json"))
    monkeypatch.delenv("GESTURELSM_ONEDNN", raising=False)
    monkeypatch.delenv("GESTURELSM_KERNELS_BUDGET", raising=False)
    choice.forget()
    yield tmp_path / "kernels.json"
    choice.forget()
