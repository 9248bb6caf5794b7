"""The served app against hostile or careless requests: every field checked before any work with
one line each (service and gradio_client), work bounded by the speech's length, TextGrids that miss the
audio, unguessable output names, files swept on a timer and at shutdown, one log line per refused request,
and a bounded loopback load test that sees "Queue is full" past the queue's size."""
from __future__ import annotations

import logging
import re
import threading
import time
from dataclasses import replace
from pathlib import Path

import pytest
import soundfile as sf

from gesturelsm.errors import GestureError
from gesturelsm.serve.request import Request
from gesturelsm.serve.service import GestureService

from _support import gradio_client, speech_like, until


@pytest.fixture
def no_work(service, monkeypatch):
    """Fails the test if the request gets as far as features or alignment."""
    def forbidden(*a, **k):
        raise AssertionError("features/alignment were computed for a request that should have been refused")
    monkeypatch.setattr(service.pipeline, "prepare_speech", forbidden)
    return service


def _req(path, **kw):
    """A request as the page sends it (its two step sliders as `steps` and `ddim_steps`)."""
    return Request(str(path), **{"steps": 1, "size": 256, "exports": False, **kw})


@pytest.mark.parametrize("field, value, message", [
    ("seed", None, "Seed is empty"),
    ("seed", "", "Seed is empty"),
    ("seed", 2 ** 70, "Seed must be from 0 to 4294967295"),
    ("seed", 1e30, "Seed must be from 0 to 4294967295"),
    ("seed", 1.5, "Seed must be a whole number .*not rounded"),
    ("seed", -1, "Seed must be from 0"),
    ("seed", "abc", "Seed must be a whole number"),
    ("steps", 2.5, "Steps must be a whole number"),
    ("steps", True, "Steps must be a whole number"),
    ("ddim_steps", float("inf"), "DDIM steps must be a whole number"),
    ("cfg", float("nan"), "CFG scale must be a number"),
    ("cfg", float("inf"), "CFG scale must be a number"),
    ("cfg", "abc", "CFG scale must be a number"),
    ("cfg", None, "CFG scale is empty"),
    ("methods", "gesturelsm", "Methods must be a list"),
    ("methods", ["magic"], "Unknown method 'magic'"),
    ("methods", None, "at least one method"),
    ("size", 300, "Video size must be one of 256, 384, 512, 640"),
    ("size", "384x", "Video size must be a whole number"),
    ("smoothing", "extreme", "Smoothing must be one of"),
    ("stand_in_place", "yes", "Stand in place must be true or false"),
    ("grounding", "on", "Feet on the ground must be true or false"),
    ("text", 42, "transcript must be text"),
])
def test_every_field_is_checked_before_any_work(no_work, speech_wav, field, value, message):
    with pytest.raises(GestureError, match=message) as err:
        no_work.run(_req(speech_wav, **{field: value}))
    assert len(str(err.value).splitlines()) == 1


def test_all_bad_fields_are_listed_one_line_each(no_work, speech_wav):
    with pytest.raises(GestureError) as err:
        no_work.run(_req(speech_wav, seed=2 ** 70, steps=2.5, cfg=float("nan")))
    lines = str(err.value).splitlines()
    assert len(lines) == 3 and [ln.split()[0] for ln in lines] == ["Steps", "CFG", "Seed"]


def test_whole_floats_are_accepted_as_numbers(service, speech_wav):
    req, plan = service.check(_req(speech_wav, seed=7.0, steps=2.0, size=256.0, stand_in_place=None, text=None))
    s = plan.settings
    assert (s.seed, dict(s.steps), req.size, s.post.stand_in_place, req.text) == (7, {"gesturelsm": 2}, 256, False, "")
    assert type(s.seed) is int and type(s.steps["gesturelsm"]) is int


def test_transcript_is_bounded_by_the_speech(no_work, speech_wav):
    """A transcript far longer than the speech could say (50k words for 2 s would hold the only worker for a
    minute or more) is refused before alignment (no_work fails the test if features or alignment start)."""
    with pytest.raises(GestureError, match="transcript has 50000 words"):
        no_work.run(_req(speech_wav, text="word " * 50_000))
    with pytest.raises(GestureError, match=r"for 2\.0 s of speech at most 36 words"):
        no_work.run(_req(speech_wav, text="word " * 100))              # within the 20 s limit, not within 2 s


def _short_textgrid(path: Path, intervals: list[tuple[float, float, str]], declared: int | None = None) -> Path:
    end = max([b for _, b, _ in intervals] + [1.0])
    lines = ['File type = "ooTextFile"', 'Object class = "TextGrid"', "", "0", str(end), "<exists>", "1",
             '"IntervalTier"', '"words"', "0", str(end), str(declared if declared is not None else len(intervals))]
    for a, b, t in intervals:
        lines += [repr(a), repr(b), f'"{t}"']
    path.write_text("\n".join(lines) + "\n")
    return path


def test_huge_textgrid_is_refused_by_size_before_parsing(no_work, speech_wav, tmp_path):
    """200k intervals (~4 MB) for 2 s of speech: the reader alone took minutes on such files."""
    tg = _short_textgrid(tmp_path / "big.TextGrid", [(i * 1e-5, (i + 1) * 1e-5, "w") for i in range(200_000)])
    with pytest.raises(GestureError, match=r"The TextGrid is \d+ KB; for 2\.0 s of speech at most \d+ KB"):
        no_work.run(_req(speech_wav, textgrid_path=str(tg)))


def test_textgrid_declaring_too_many_intervals_is_refused_before_reading_them(no_work, speech_wav, tmp_path):
    from gesturelsm.align.textgrid import TextGridError, parse_textgrid

    tg = _short_textgrid(tmp_path / "lying.TextGrid", [(0.0, 0.5, "hello")], declared=200_000)
    with pytest.raises(GestureError, match="has 200000 intervals; at most 180 are accepted"):
        no_work.run(_req(speech_wav, textgrid_path=str(tg)))
    with pytest.raises(TextGridError, match="at most 10"):
        parse_textgrid(tg.read_text(), max_intervals=10)


def test_textgrid_words_all_after_the_audio_are_refused(no_work, speech_wav, tmp_path):
    from gesturelsm.align import Word, write_textgrid

    tg = tmp_path / "late.TextGrid"
    write_textgrid(tg, [Word("hello", 10.0, 10.5), Word("world", 10.6, 11.0)], duration=12.0)
    with pytest.raises(GestureError, match=r"All 2 words of the TextGrid lie after the end of the speech"):
        no_work.run(_req(speech_wav, textgrid_path=str(tg)))


def test_textgrid_words_partly_after_the_audio_are_dropped_and_said(service, speech_wav, tmp_path):
    from gesturelsm.align import Word, write_textgrid

    tg = tmp_path / "partly.TextGrid"
    write_textgrid(tg, [Word("hello", 0.2, 0.6), Word("world", 5.0, 5.5)], duration=6.0)
    out = service.run(_req(speech_wav, textgrid_path=str(tg)))
    assert out.text_mode == "transcript with given word timings"
    assert any("1 of the TextGrid's 2 words start after the end" in w for w in out.warnings)
    assert re.fullmatch(r"req-[0-9a-f]{32}", out.video.parent.name)        # 128 random bits, no timestamp


def test_outputs_are_swept_on_a_timer_and_at_shutdown(service, tmp_path):
    import os

    from gesturelsm.serve.lifetime import Sweeper

    svc = GestureService(service.pipeline, replace(service.settings, workdir=str(tmp_path), keep_minutes=1),
                         service.body)
    old, fresh = tmp_path / "req-old", tmp_path / "req-fresh"
    old.mkdir(), fresh.mkdir()
    past = time.time() - 3600
    os.utime(old, (past, past))
    sweeper = Sweeper(svc.cleanup, 0.05, final=lambda: svc.cleanup(max_age_s=0)).start()
    until(lambda: not old.exists(), "the timer swept the hour-old folder", every=0.05)   # no request meanwhile
    assert fresh.exists()
    sweeper.stop()                                                     # shutdown: everything goes
    assert not fresh.exists()


def test_gradio_cache_lifetime_follows_keep_minutes(service):
    from gesturelsm.serve.lifetime import gradio_delete_cache, sweep_seconds
    from gesturelsm.webapp.ui import build_demo

    demo = build_demo(GestureService(service.pipeline, replace(service.settings, keep_minutes=1), service.body))
    assert demo.blocks.delete_cache == (15, 60) == gradio_delete_cache(1)
    assert sweep_seconds(60) == 60 and sweep_seconds(0.1) == 5


@pytest.mark.parametrize("position, value, message", [
    (6, 2 ** 70, "Seed must be from 0 to 4294967295"),
    (6, 1e30, "Seed must be from 0 to 4294967295"),
    (6, None, "Seed is empty"),
    (6, 1.5, "Seed must be a whole number"),
    (4, 2.5, "Steps must be a whole number"),
    (5, "abc", "CFG scale must be a number"),
    (5, None, "CFG scale is empty"),
    (10, 300, "Video size must be one of"),
    (3, ["magic"], "Unknown method 'magic'"),
])
def test_api_bad_fields_get_the_same_one_line_message(app_url, speech_wav, position, value, message):
    from gradio_client import handle_file

    args = [handle_file(str(speech_wav)), "", None, ["gesturelsm"], 1, 2.0, 0, 20, False, "off", 256]
    args[position] = value
    with pytest.raises(Exception, match=message):
        gradio_client(app_url).predict(*args, api_name="/generate")


def test_refused_request_logs_one_line_without_traceback(app_url, speech_wav, caplog, capfd):
    from gradio_client import handle_file

    with caplog.at_level(logging.INFO, logger="gesturelsm.app"):
        with pytest.raises(Exception, match="Seed must be"):
            gradio_client(app_url).predict(handle_file(str(speech_wav)), "", None, ["gesturelsm"], 1, 2.0, 2 ** 70, 20,
                                           False, "off", 256, api_name="/generate")
    err = capfd.readouterr().err
    assert "Traceback" not in err
    refused = [r for r in caplog.records if r.name == "gesturelsm.app" and "request refused" in r.getMessage()]
    assert len(refused) == 1 and "\n" not in refused[0].getMessage()


def test_load_eight_concurrent_requests_served_then_queue_full(service, tmp_path):
    """Loopback only, bounded: 12 requests at once at 1 s of audio, 1 step, 256 px, with one worker and a
    queue of 8. At least 8 are served; the rest are refused with Gradio's 'Queue is full'."""
    from gradio_client import handle_file

    from gesturelsm.webapp.ui import serve_locally

    wav = tmp_path / "one_second.wav"
    sf.write(wav, speech_like(1.0, seed=11), 16000)
    demo, url = serve_locally(service, queue_size=8)
    assert url.startswith("http://127.0.0.1:")
    results: list[tuple[str, str]] = []

    def one(seed: int) -> None:
        try:
            payload, *_ = gradio_client(url).predict(handle_file(str(wav)), "", None, ["gesturelsm"], 1, 2.0, seed, 20,
                                                     False, "off", 256, api_name="/generate_motion")
            results.append(("served", payload))
        except Exception as exc:                                       # the outcome is checked
            results.append(("refused", str(exc)))

    try:
        threads = [threading.Thread(target=one, args=(s,), daemon=True) for s in range(12)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(timeout=240)
        assert not any(t.is_alive() for t in threads), "the load test did not finish in time"
    finally:
        demo.close()
    served = [v for kind, v in results if kind == "served"]
    refused = [m for kind, m in results if kind == "refused"]
    assert len(served) >= 8 and all(p["frames"] == 30 and len(p["bodies"]) == 1 for p in served)   # 1 s of motion
    assert refused and all("queue is full" in m.lower() for m in refused), refused
