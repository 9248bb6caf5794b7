"""Commit and look-ahead: the live default is set in one place (LiveConfig) and a chosen commit / look-ahead is what
the stream does: each chunk holds `commit` latents and comes out the moment the audio reaches `lookahead` latents
past it (tiny checkpoints, no timing)."""
from __future__ import annotations

import argparse
import inspect
from dataclasses import fields

import pytest
import soundfile as sf

from gesturelsm.generator.data import samples_for
from gesturelsm.live import LiveConfig, StreamingGenerator
from gesturelsm.commands.live import add_parser, check_arguments
from gesturelsm.live.from_file import run_file
from gesturelsm.live.session import LiveManager, LiveSession

from _support import speech_like


def live_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser()
    add_parser(ap.add_subparsers())
    return ap


def test_the_live_default_is_set_in_one_place(tmp_path):
    """The CLI's flags, the session manager (the Live tab), the session, the generator and run_file all take their
    defaults from LiveConfig: changing the default there changes it everywhere."""
    default = LiveConfig()
    for f in (StreamingGenerator.__init__, LiveSession.__init__, LiveManager.__init__, run_file):
        assert inspect.signature(f).parameters["config"].default == default, f.__qualname__
    wav = tmp_path / "s.wav"
    sf.write(wav, speech_like(0.5), 16000)
    args = live_parser().parse_args(["live", str(wav)])
    cfg = check_arguments(args)[0]
    for f in fields(LiveConfig):
        assert getattr(cfg, f.name) == getattr(default, f.name), f.name


@pytest.mark.parametrize("commit, lookahead", [(1, 0), (2, 1), (1, 2), (3, 1)])
def test_a_chosen_commit_and_lookahead_are_honoured(tiny_pipeline, tmp_path, commit, lookahead):
    """Chunk k holds latents [k c, (k + 1) c) (4 c frames) and is emitted by the feed that brings the audio to latent
    (k + 1) c + lookahead, not before; the CLI's --commit / --lookahead reach the stream unchanged."""
    wav = tmp_path / "s.wav"
    sf.write(wav, speech_like(0.5), 16000)
    args = live_parser().parse_args(["live", str(wav), "--commit", str(commit), "--lookahead", str(lookahead),
                                     "--steps", "1"])
    cfg = check_arguments(args)[0]
    assert (cfg.commit, cfg.lookahead) == (commit, lookahead)

    y = speech_like(3.0, seed=11)
    block = 500                                                    # under a latent (2133 samples): finer than a commit
    gen = StreamingGenerator(tiny_pipeline, cfg)
    seen = []
    for a in range(0, len(y), block):
        n_in = min(a + block, len(y))
        for mc in gen.feed(y[a:a + block]):
            seen.append((mc, n_in))
    assert len(seen) >= 4
    for k, (mc, n_in) in enumerate(seen):
        assert (mc.start, mc.stop) == (4 * commit * k, 4 * commit * (k + 1))
        need = samples_for(4 * ((k + 1) * commit + lookahead))     # audio up to `lookahead` latents past the chunk
        assert n_in - block < need <= n_in, (k, n_in, need)
        assert mc.audio_ahead_s == pytest.approx((n_in - samples_for(mc.stop)) / 16000)
        assert lookahead * 4 / 30 - 1e-3 <= mc.audio_ahead_s < lookahead * 4 / 30 + block / 16000
    rest = gen.finish()
    assert rest and rest[0].start == seen[-1][0].stop
    assert rest[-1].stop == len(y) * 30 // 16000


def test_without_lookahead_the_decoder_still_has_a_right_context(tiny_pipeline):
    """Look-ahead 0: no latent of the window lies right of a chunk; the decoder gets the chunk's last latent repeated
    there, so every chunk leaves a decode of the frames after it for the next one to fade from (the seam fade)."""
    cfg = LiveConfig(commit=2, lookahead=0, steps=1, grounding=False)
    y = speech_like(2.0, seed=12)
    gen = StreamingGenerator(tiny_pipeline, cfg)
    chunks = []
    for a in range(0, len(y), 700):
        for mc in gen.feed(y[a:a + 700]):
            chunks.append(mc)
            assert mc.audio_ahead_s < 700 / 16000                   # emitted as soon as its own audio is in
            assert len(gen.tail) == cfg.blend_frames                 # the frames after it, decoded now
    assert len(chunks) >= 3



def test_without_lookahead_seams_are_no_rougher_than_inside(shipped_pipe):
    """The shipped generator at commit 2 / look-ahead 0 (the fast setting): with the repeated latent on the decoder's
    right the jerk at seams stays at the inside's (0.84-0.99 on the held-out takes; without it 6.3x), as
    tests/live/test_stream.py holds the default to."""
    import numpy as np

    y = speech_like(9.0, seed=5)
    gen = StreamingGenerator(shipped_pipe, LiveConfig(commit=2, lookahead=0, steps=1))
    out = list(gen.stream([y[a:a + 3200] for a in range(0, len(y), 3200)]))
    poses = np.concatenate([c.motion.poses for c in out])
    jerk = np.abs(np.diff(poses, n=3, axis=0)).mean(1)
    seam = np.zeros(len(jerk), bool)
    for c in out[1:]:
        seam[max(0, c.start - 3):c.start] = True
    assert jerk[seam].mean() <= 1.2 * jerk[~seam].mean()
