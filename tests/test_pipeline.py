"""The pipeline on tiny checkpoints. Audio-only (transcribe=False) wherever a test is not about where the words come
from (tests/test_pipeline_transcript.py and the CLI test are): the recogniser rejects these synthetic tones
anyway, after 21 s of CPU for 30 s of them, far longer than generating."""
import numpy as np
import pytest
import soundfile as sf
import torch

from gesturelsm.generator.sampling import window_layout
from gesturelsm.pipeline import InputError

from _support import speech_like


def test_fixed_seed_gives_identical_output_and_other_seeds_differ(tiny_pipeline):
    y = speech_like(6.0)
    a = tiny_pipeline.generate(y, 16000, steps=4, cfg=2.0, seed=3, transcribe=False, output="raw")
    b = tiny_pipeline.generate(y, 16000, steps=4, cfg=2.0, seed=3, transcribe=False, output="raw")
    c = tiny_pipeline.generate(y, 16000, steps=4, cfg=2.0, seed=4, transcribe=False, output="raw")
    np.testing.assert_array_equal(a.motion.poses, b.motion.poses)
    assert not np.allclose(a.motion.poses, c.motion.poses)


@pytest.mark.parametrize("seconds", [0.5, 1.0, 4.27, 30.0])
def test_output_has_the_speech_length(tiny_pipeline, seconds):
    res = tiny_pipeline.generate(speech_like(seconds), 16000, steps=2, transcribe=False, output="raw")
    assert res.motion.num_frames == int(seconds * 30)
    assert np.isfinite(res.motion.poses).all() and np.isfinite(res.motion.trans).all()
    assert set(res.timings) >= {"features", "sampling", "decoding"}


def test_window_layout_covers_everything_with_overlap():
    for L in [1, 8, 31, 32, 33, 100, 1000]:
        starts = window_layout(L, 32, 4)
        assert starts[0] == 0 and starts[-1] + 32 >= L
        assert all(b - a == 28 for a, b in zip(starts, starts[1:]))


def test_every_method_and_any_sample_rate(tiny_pipeline):
    y16 = speech_like(3.0)
    import scipy.signal

    y44 = scipy.signal.resample_poly(y16, 441, 160).astype(np.float32)
    for method, steps in [("gesturelsm", 1), ("rectified_flow", 2), ("ddim", 5)]:
        r = tiny_pipeline.generate(y44, 44100, steps=steps, method=method, transcribe=False, output="raw")
        assert r.motion.num_frames == 90 and r.method == method
    stereo = np.stack([y16, y16], 1)
    assert tiny_pipeline.generate(stereo, 16000, steps=1, transcribe=False, output="raw").motion.num_frames == 90


def test_cfg_one_equals_conditional_and_changes_with_scale(tiny_pipeline):
    """CFG 1 is the conditional prediction alone: replacing the learned null condition by a wild one leaves the
    sampled latents bit-identical, while at CFG 3 the null branch is used (the wild null changes them) and the
    motion differs from CFG 1. Compared on latents, before decoding re-quantises them to the nearest codes (which
    would hide small differences)."""
    from gesturelsm.generator.sampling import generate_latents

    sp = tiny_pipeline.prepare_speech(speech_like(4.0), 16000, transcribe=False)
    gen = tiny_pipeline.generators["gesturelsm"]

    def latents(cfg: float) -> torch.Tensor:
        return generate_latents(gen, sp.channels, sp.word_features, sp.has_word, sp.words is not None,
                                sp.num_frames, steps=2, cfg_scale=cfg, seed=0)

    a, b = latents(1.0), latents(3.0)
    assert (a - b).abs().max() > 1e-2 * a.abs().max()
    assert not np.allclose(tiny_pipeline.generate(sp, steps=2, cfg=1.0, output="raw").motion.poses,
                           tiny_pipeline.generate(sp, steps=2, cfg=3.0, output="raw").motion.poses)
    saved = gen.null_cond.detach().clone()
    try:
        with torch.no_grad():
            gen.null_cond.normal_(0.0, 30.0, generator=torch.Generator().manual_seed(1))   # a wild null condition
        a_wild, b_wild = latents(1.0), latents(3.0)
    finally:
        with torch.no_grad():
            gen.null_cond.copy_(saved)
    assert torch.equal(a_wild, a)
    assert (b_wild - b).abs().max() > 1e-2 * b.abs().max()


@pytest.mark.parametrize("kwargs,msg", [
    (dict(steps=0), "Steps for GestureLSM must be"), (dict(steps=500), "Steps for GestureLSM must be"),
    (dict(cfg=-1.0), "CFG scale"),
    (dict(cfg=float("nan")), "CFG scale"), (dict(method="magic"), "unknown method"),
])
def test_absurd_settings_are_refused_with_a_message(tiny_pipeline, kwargs, msg):
    with pytest.raises(InputError, match=msg):
        tiny_pipeline.generate(speech_like(1.0), 16000, **kwargs, output="raw")


def test_bad_audio_is_refused_with_a_message(tiny_pipeline):
    with pytest.raises(InputError, match="silent"):
        tiny_pipeline.generate(np.zeros(32000, np.float32), 16000, output="raw")
    with pytest.raises(InputError, match="at least"):
        tiny_pipeline.generate(speech_like(0.2), 16000, output="raw")
    with pytest.raises(InputError, match="invalid"):
        tiny_pipeline.generate(np.full(32000, np.nan, np.float32), 16000, output="raw")
    long = GesturePipelineWithLimit(tiny_pipeline, 5.0)
    with pytest.raises(InputError, match="limit"):
        long.generate(speech_like(6.0), 16000, output="raw")


@pytest.mark.parametrize("has_text", [False, True])
def test_batched_speech_conditions_equal_one_window_at_a_time(tiny_pipeline, has_text):
    """generate_latents computes the speech condition for several windows in one call; every window must get
    exactly what a call for that window alone gives (tiny windows: 30 s is many of them, across 3 batches)."""
    from gesturelsm.generator.sampling import generate_latents

    gen = tiny_pipeline.generators["gesturelsm"]
    sp = tiny_pipeline.prepare_speech(speech_like(30.0), 16000, transcribe=False)
    T = sp.num_frames
    words = torch.randn(T, sp.word_features.shape[1]) if has_text else sp.word_features
    has_word = torch.rand(T) < 0.6 if has_text else sp.has_word
    n_windows = len(window_layout(-(-T // 4), gen.config.window_latents, gen.config.seed_latents))
    assert n_windows > 16
    one, many = (generate_latents(gen, sp.channels, words, has_word, has_text, T, 2, 2.0, 0, cond_batch=b)
                 for b in (1, 7))
    torch.testing.assert_close(many, one, rtol=1e-4, atol=1e-5)


def test_every_length_fits_the_shipped_window_size():
    """With 128-frame windows a window is 68,266.7 samples: rounding must never leave a window short."""
    from dataclasses import replace

    from gesturelsm.generator.config import PRESETS
    from gesturelsm.generator.data import samples_for
    from gesturelsm.generator.model import GestureGenerator
    from gesturelsm.generator.sampling import generate_latents

    torch.manual_seed(0)
    gen = GestureGenerator(replace(PRESETS["tiny"], window_latents=32, seed_latents=4)).eval()
    for frames in (244, 245, 246, 247, 300, 1801):                 # 61+ latents: the 3rd window's rounding
        audio = torch.rand(2, samples_for(frames))
        lat = generate_latents(gen, audio, torch.zeros(frames, 384), torch.zeros(frames, dtype=torch.bool), False,
                               frames, 1, 2.0, 0)
        assert lat.shape[1] == -(-frames // 4) and torch.isfinite(lat).all()


def GesturePipelineWithLimit(pipe, seconds):
    from gesturelsm.pipeline import GesturePipeline

    return GesturePipeline.from_models(pipe.tokenizers, pipe.generators, max_seconds=seconds)


def test_long_audio_stitches_windows_without_jumps(tiny_pipeline):
    """No velocity spike at window borders compared with inside windows."""
    res = tiny_pipeline.generate(speech_like(40.0), 16000, steps=2, seed=1, transcribe=False, output="raw")
    gen = tiny_pipeline.generators["gesturelsm"]
    t, s = gen.config.window_latents, gen.config.seed_latents
    feats = res.motion.to_features()
    vel = (feats[1:, :330] - feats[:-1, :330]).abs().max(dim=1).values        # (T-1,) max 6D change per frame
    borders = [4 * (st + s // 2) for st in window_layout(feats.shape[0] // 4, t, s)[1:]]
    near = torch.tensor([vel[max(0, b - 4):b + 4].max().item() for b in borders if b + 4 < len(vel)])
    assert len(near) >= 3
    assert near.max() <= 2.0 * vel.quantile(0.99), (near.max(), vel.quantile(0.99))


def test_generate_cli_writes_beat2_npz(tiny_assets, tmp_path, capsys):
    from gesturelsm.cli import main

    wav = tmp_path / "speech.wav"
    sf.write(wav, speech_like(3.0, sr=22050), 22050)
    out = tmp_path / "out.npz"
    assert main(["generate", str(wav), "--checkpoints", str(tiny_assets), "--steps", "2", "--out", str(out)]) == 0
    with np.load(out) as d:
        assert d["poses"].shape == (90, 165) and d["trans"].shape == (90, 3) and d["expressions"].shape == (90, 100)
        assert int(d["mocap_frame_rate"]) == 30
    assert "real-time factor" in capsys.readouterr().out
    # the default post-processing is light smoothing then feet on the ground, of the raw model output (the same
    # seed with --smoothing off --grounding off); --grounding off leaves the smoothed motion's root and legs
    from gesturelsm.motion import MotionSequence
    from gesturelsm.motion.postprocess import DEFAULT_SMOOTHING, postprocess
    from gesturelsm.pipeline import finish

    raw, ungrounded = tmp_path / "raw.npz", tmp_path / "ungrounded.npz"
    for path, extra in ((raw, ["--smoothing", "off", "--grounding", "off"]), (ungrounded, ["--grounding", "off"])):
        assert main(["generate", str(wav), "--checkpoints", str(tiny_assets), "--steps", "2", *extra,
                     "--out", str(path)]) == 0
    raw = MotionSequence.load(raw)
    default, want = MotionSequence.load(out), finish(raw, False, DEFAULT_SMOOTHING, True)[0]
    assert DEFAULT_SMOOTHING == "light" and np.allclose(default.poses, want.poses, atol=1e-5)
    np.testing.assert_allclose(default.trans, want.trans, atol=1e-5)
    smoothed = postprocess(raw, False, DEFAULT_SMOOTHING)
    np.testing.assert_allclose(MotionSequence.load(ungrounded).poses, smoothed.poses, atol=1e-5)
    assert not np.allclose(smoothed.poses, raw.poses, atol=1e-4)
    assert not np.allclose(default.trans, smoothed.trans, atol=1e-3)          # grounding moved the root
    (tmp_path / "broken.wav").write_bytes(b"RIFF....WAVEfmt garbage")
    assert main(["generate", str(tmp_path / "broken.wav"), "--checkpoints", str(tiny_assets), "--out",
                 str(tmp_path / "x.npz")]) == 2
    err = capsys.readouterr().err
    assert "broken.wav" in err and "Traceback" not in err


def test_transcript_falls_back_to_audio_only_with_a_warning_when_text_encoder_is_missing(tiny_pipeline, monkeypatch,
                                                                                          tmp_path):
    from dataclasses import dataclass

    from gesturelsm.features.text import TextEmbedder

    @dataclass
    class W:
        text: str
        start: float
        end: float

    monkeypatch.setattr(TextEmbedder, "_shared", TextEmbedder(model_dir=str(tmp_path / "missing")))
    res = tiny_pipeline.generate(speech_like(2.0), 16000, words=[W("hello", 0.2, 0.8)], steps=1, output="raw")
    assert res.text_mode.startswith("audio-only") and any("unavailable" in w for w in res.warnings)
    assert res.motion.num_frames == 60
