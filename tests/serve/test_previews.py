"""The first method's motion streamed window by window to the page (generator/sampling.py `window_previews`,
serve/preview.py, serve/progressive.py with previews, the player payload's `partial` bodies), on tiny checkpoints:
the previews come before the first method is made and grow, they change nothing of the motion made (bit for bit the
same as without them, made ahead or not), and the page's payloads start with fewer frames than the whole and end on
the finished motion."""
from __future__ import annotations

import numpy as np
import torch

from gesturelsm.serve.request import Request

ALL = ["gesturelsm", "rectified_flow", "ddim"]
STEPS = {"gesturelsm": 3, "rectified_flow": 1, "ddim": 2}
FIRST = "rectified_flow"                     # the fewest steps: made first


def _request(wav, **kw) -> Request:
    return Request(str(wav), methods=ALL, steps=dict(STEPS), exports=False, render=False, **kw)


def _same(a, b) -> None:
    for m in ALL:
        np.testing.assert_array_equal(a.motions[m].poses, b.motions[m].poses)
        np.testing.assert_array_equal(a.motions[m].trans, b.motions[m].trans)
        np.testing.assert_array_equal(a.motions[m].expressions, b.motions[m].expressions)


def test_window_decoding_leaves_the_latents_as_they_were(tiny_pipeline):
    from _support import speech_like

    from gesturelsm.generator.sampling import generate_latents, window_decoder, window_previews
    from gesturelsm.serve.preview import Preview

    speech = tiny_pipeline.prepare_speech(speech_like(3.0), transcribe=False)
    backend = tiny_pipeline.backends["gesturelsm"]
    args = (backend.model, speech.channels, speech.word_features, speech.has_word, False, speech.num_frames, 2, 2.0, 7)
    plain = generate_latents(*args)
    assert window_decoder(backend.tokenizers, speech.num_frames) is None          # no listener: nothing decoded
    preview = Preview()
    with window_previews(preview):
        decoder = window_decoder(backend.tokenizers, speech.num_frames)
        watched = generate_latents(*args, on_window=decoder)
    torch.testing.assert_close(watched, plain, rtol=0, atol=0)
    assert preview.version >= 1 and 0 < preview.motion.num_frames < speech.num_frames


def test_the_first_method_grows_before_it_is_made_and_ends_finished(service, speech_wav):
    """Audio only: a method whose automatic words turn out to be other words is made again (pipelined.Restart), and
    its previews start again with it."""
    results = list(service.stream(_request(speech_wav, transcribe=False)))
    first = next(i for i, r in enumerate(results) if r.motions)
    grown = [(i, r) for i, r in enumerate(results) if r.previews]
    assert grown and all(i < first for i, _ in grown)                              # only before a body moves
    assert all(list(r.previews) == [FIRST] and FIRST in r.pending for _, r in grown)
    frames = [r.previews[FIRST].num_frames for _, r in grown]
    T = results[-1].motions[FIRST].num_frames
    assert frames == sorted(set(frames)) and 0 < frames[0] and frames[-1] < T     # growing, never the whole
    assert results[-1].previews == {} and results[-1].pending == ()
    _same(results[-1], service.run(_request(speech_wav, transcribe=False)))       # bit for bit as without
    plain = list(service.stream(_request(speech_wav, transcribe=False), previews=False))
    assert not any(r.previews for r in plain) and len(plain) == len(results) - len(grown)
    _same(results[-1], plain[-1])


def test_motion_made_ahead_streams_its_first_windows_too(service, speech_wav):
    req = _request(speech_wav)
    run = service.make_ahead(req)
    assert run is not None
    run.thread.join()
    assert run.preview.version >= 1 and run.preview.stopped                      # previews, then the first method
    assert 0 < run.preview.motion.num_frames < run.made[0].motion.num_frames
    _same(list(service.stream(req))[-1], service.run(_request(speech_wav)))


def test_the_page_payload_starts_partial_and_ends_on_the_finished_motion(service, speech_wav):
    from gesturelsm.export.player_payload import motion_record, read_motion
    from gesturelsm.webapp.player import component

    results = list(service.stream(_request(speech_wav, transcribe=False)))
    payloads = [component.payload(service, r) for r in results]
    index = ALL.index(FIRST)

    def path(url: str):
        return url.removeprefix("gradio_api/file=")
    partial = [p["bodies"][index] for p in payloads if p["bodies"][index].get("partial")]
    assert partial and all(b["motion"] for b in partial)
    T = results[-1].motions[FIRST].num_frames
    first = read_motion(path(partial[0]["motion"]))
    assert partial[0]["frames"] == len(first.rotations) < T                      # fewer frames than the whole
    last = payloads[-1]["bodies"][index]
    assert not last.get("partial") and last["motion"] not in {b["motion"] for b in partial}
    shown, finished = read_motion(path(last["motion"])), motion_record(results[-1].motions[FIRST], service.body)
    np.testing.assert_array_equal(shown.rotations, finished.rotations)            # the finished motion
    np.testing.assert_array_equal(shown.root, finished.root)
    assert len(shown.rotations) == T
