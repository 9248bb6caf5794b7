"""The page's chained events (gesturelsm/webapp/ui.py _Handlers): the video renders in a pool of its own beside
generation, and a video for a request that a newer request of the same page replaced is not rendered, or is stopped
mid-way."""
from __future__ import annotations

import threading
from pathlib import Path
from types import SimpleNamespace

import gradio as gr

from _support import quiet
from gesturelsm.webapp.ui import _Handlers, build_demo


def inputs(wav, seed: int, grounding: bool = True) -> tuple:
    # audio, text, textgrid, methods, steps, cfg, seed, ddim_steps, in_place, smoothing, size, auto_text, grounding,
    # language
    return (str(wav), "", None, ["gesturelsm"], 1, 2.0, seed, 2, False, "light", 256, False, grounding, "auto")


def made(h, *args, **kw):
    """The request the button's handler ends with (it yields the page's outputs after each method made)."""
    return list(h.show_motion(*args, **kw))[-1][3]


def test_video_and_downloads_run_in_their_own_pool_beside_generation(service):
    demo = build_demo(service)
    fns = demo.blocks.fns
    fns = list(fns.values() if isinstance(fns, dict) else fns)
    pools = {f.api_name: f.concurrency_id for f in fns}
    assert pools["generate_motion"] == "generation"
    # the downloads in a pool of their own, before the video (nobody's video holds them up); the videos' pool lets
    # every step in, the service's render queue keeps one video at a time (serve/renders.py)
    assert pools["show_video"] == "render" and pools["add_exports"] == "exports"
    assert len({pools["show_video"], pools["add_exports"], pools["generate_motion"]}) == 3
    limits = {f.api_name: f.concurrency_limit for f in fns}
    assert limits["show_video"] is None and limits["add_exports"] == service.settings.concurrency
    # a newer request's video step is queued while an older one's is pending (Gradio's default "once" drops it)
    modes = {f.api_name: f.trigger_mode for f in fns}
    assert modes["show_video"] == modes["add_exports"] == "multiple"


def test_gradio_hands_the_handlers_the_page_session():
    """Gradio passes gr.Request (and progress) only to positional parameters: a *args handler gets none, and then
    nothing is ever marked replaced."""
    from gradio.helpers import special_args

    h, page = _Handlers.__new__(_Handlers), SimpleNamespace(session_hash="page-1")
    for fn, n_inputs, progress in ((h.show_motion, 16, True), (h.show_video, 2, True), (h.add_exports, 2, False)):
        filled, progress_at, _, _ = special_args(fn, list(range(n_inputs)), request=page)
        assert filled[n_inputs] is page and progress_at == (n_inputs + 1 if progress else None)


def test_a_late_downloads_event_never_puts_back_fewer_files_than_the_exports(service, speech_wav):
    """The npz + BVH event follows the player's payload and waits behind the statistics, so it can run after the
    exports with the state it was triggered with (no downloads yet): it answers with the whole list, GLB included."""
    h, page = _Handlers(service), SimpleNamespace(session_hash="page-1")
    stale = made(h, *inputs(speech_wav, 0), request=page, progress=quiet)
    early = h.made_downloads(stale, request=page)
    assert sorted(Path(f).suffix for f in early) == [".bvh", ".npz"]          # before the exports: what is made
    files = h.add_exports(stale, request=page)[0]
    assert any(f.endswith(".glb") for f in files) and len(files) > len(early)
    assert h.made_downloads(stale, request=page) == files                    # late, with the stale state


def test_a_replaced_request_gets_no_video_and_a_running_render_stops(service, speech_wav):
    h, page, other = _Handlers(service), SimpleNamespace(session_hash="page-1"), SimpleNamespace(session_hash="page-2")
    first = made(h, *inputs(speech_wav, 0), request=page, progress=quiet)
    second = made(h, *inputs(speech_wav, 1), request=page, progress=quiet)
    assert h.show_video(first, request=page, progress=quiet) == (gr.skip(),) * 4     # replaced: not rendered
    assert not list(first.job.folder.glob("*.mp4")) and h.add_exports(first, request=page) == (gr.skip(),) * 4
    assert not h._replaced(other, first), "another page's requests replace nothing of this page's"

    started, result = threading.Event(), {}

    def progress(fraction, desc=""):
        if desc.startswith("rendering: frame"):
            started.set()

    t = threading.Thread(target=lambda: result.update(r=h.show_video(second, request=page, progress=progress)))
    t.start()
    assert started.wait(120), "the render reported frames"
    third = made(h, *inputs(speech_wav, 2), request=page, progress=quiet)   # generate again, meanwhile
    t.join(120)
    assert result["r"] == (gr.skip(),) * 4
    folder = second.job.folder
    assert not [p.name for p in folder.iterdir() if p.suffix == ".mp4" or p.name.startswith(".render-job")]
    video, _rows, _summary, rendered = h.show_video(third, request=page, progress=quiet)   # the newest one renders
    assert third.video is None, "the state's result is not edited: the rendered one replaces it"
    assert video == str(rendered.video) and rendered.video.stat().st_size > 1000 and rendered.job is third.job
    files, glb, summary, exported = h.add_exports(rendered, request=page)        # and then its downloads
    assert exported.video == rendered.video and glb == str(exported.glb) and "Video ready" in summary
    assert sorted(files) == sorted(map(str, exported.downloads)) and rendered.downloads == ()


def test_the_feet_on_the_ground_box_grounds_every_shown_motion(service, speech_wav):
    """The page's option (elem_id `grounding`, ticked by default, an input of both generate endpoints) reaches the
    request: unticked, the motion is the smoothed decoder output; ticked, that motion with its feet grounded
    (pipeline.finish on the service's body), everything above the pelvis bit for bit the same."""
    import numpy as np

    from gesturelsm.grounding import CHANGED_JOINTS
    from gesturelsm.pipeline import finish

    cfg = build_demo(service).blocks.get_config_file()
    box = next(c for c in cfg["components"] if c["props"].get("elem_id") == "grounding")
    assert box["props"]["value"] is True
    deps = {d.get("api_name"): d for d in cfg["dependencies"]}
    assert box["id"] in deps["generate_motion"]["inputs"] and box["id"] in deps["generate"]["inputs"]
    h = _Handlers(service)
    on = made(h, *inputs(speech_wav, 0, True), progress=quiet).motions["gesturelsm"]
    off = made(h, *inputs(speech_wav, 0, False), progress=quiet).motions["gesturelsm"]
    want, note = finish(off, grounding=True, body=service.body)
    assert note is None
    np.testing.assert_array_equal(on.poses, want.poses)
    np.testing.assert_array_equal(on.trans, want.trans)
    keep = [c for j in range(55) if j not in CHANGED_JOINTS for c in range(3 * j, 3 * j + 3)]
    assert np.array_equal(on.poses[:, keep], off.poses[:, keep]) and not np.allclose(on.trans, off.trans)


def test_new_speech_clears_recognised_words_and_keeps_typed_ones_with_a_note():
    """Speech uploaded, recorded or removed: the words the page recognised for earlier speech leave the box; words
    the visitor typed stay, with the note shown; an empty box stays empty and the note hidden."""
    from gesturelsm.webapp.layout import TYPED_NOTE
    from gesturelsm.webapp.words import new_speech

    words = {"audio": "/up/a.wav", "text": "hello there"}
    text, note, kept = new_speech(" hello there ", words)
    assert text == "" and note["visible"] is False and kept is None
    text, note, kept = new_speech("my own words", words)
    assert text == gr.skip() and note == {"__type__": "update", "value": TYPED_NOTE, "visible": True} and kept is words
    text, note, kept = new_speech("", words)
    assert text == gr.skip() and note["visible"] is False and kept is None


def test_a_request_never_uses_the_words_recognised_for_another_upload():
    """The box still holds the words recognised for upload A (a generation of A finished after B was uploaded): a
    request for B transcribes B itself; for A, or with words the visitor typed, the box's words are used."""
    from gesturelsm.webapp.words import own_words

    words = {"audio": "/up/a.wav", "text": "hello there"}
    assert own_words("/up/b.wav", "hello there", words) == ""
    assert own_words("/up/a.wav", "hello there", words) == "hello there"
    assert own_words("/up/b.wav", "typed words", words) == "typed words"
    assert own_words("/up/b.wav", "typed words", None) == "typed words"


def test_the_button_sends_the_recognised_words_with_their_upload_and_a_status(service, speech_wav, hears_hello):
    service.uploads.clear()            # speech another test of this worker prepared (its words) is not heard again
    h = _Handlers(service)
    outs = list(h.show_motion(*inputs(speech_wav, 0)[:11], True, True, "auto", None, None, progress=quiet))
    payload, _table, _summary, out, text, words, status = outs[-1]
    assert text == "hello there" and words == {"audio": str(speech_wav), "text": "hello there"}
    assert status.startswith("**Motion made** for 1 of 1 methods")


def test_a_growing_preview_hands_the_player_its_payload_and_redraws_nothing_else(service, speech_wav):
    """Each longer preview of the method being made (serve/preview.py) changes the player's payload alone: the timing
    table, summary, transcript, words and status line are left as they are (redrawing them competed with the first
    body for the browser), and every other yield fills the table, summary and status line."""
    h = _Handlers(service)
    args = (str(speech_wav), "", None, ["gesturelsm", "rectified_flow", "ddim"], 1, 2.0, 0, 2, False, "light", 256,
            False, True, "auto")
    outs = list(h.show_motion(*args, progress=quiet))
    grows = [any(b.get("partial") for b in o[0]["bodies"]) for o in outs]
    assert any(grows) and not grows[0] and not grows[-1], grows       # the speech first, the finished motion last
    for o, grown in zip(outs, grows):
        assert o[3].previews if grown else not o[3].previews            # the page's state: every result
        boxes = (o[1], o[2], o[4], o[5], o[6]) if grown else (o[1], o[2], o[6])
        assert all((v == gr.skip()) == grown for v in boxes), (grown, boxes)
    assert outs[-1][6].startswith("**Motion made** for 3 of 3 methods") and outs[-1][1]
