"""The page's motion statistics (gesturelsm/webapp/stats_view.py) and Sweep tab (gesturelsm/webapp/sweep_tab.py), driven
through their handlers on tiny checkpoints: the numbers are `gesturelsm eval`'s definitions and the same as `gesturelsm
sweep` prints."""
from __future__ import annotations

import json
import re
import shutil

import gradio as gr
import numpy as np
import pytest
import soundfile as sf

from _support import quiet
from gesturelsm.serve.request import Request
from gesturelsm.webapp import stats_view
from gesturelsm.webapp.sweep_tab import SweepHandlers
from gesturelsm.cli import main
from gesturelsm.evaluation.evaluate import motion_stats as eval_motion_stats
from gesturelsm.evaluation.motion_stats import STATISTICS, SpeechContext, speaker_reference, stats_body


def test_page_statistics_equal_the_eval_definitions_for_the_shown_motions(service, speech_wav):
    out = service.run(Request(str(speech_wav), methods=("gesturelsm", "ddim"), render=False, exports=False))
    page = stats_view.show(out)
    shown = stats_view.values(page)
    assert list(shown) == ["gesturelsm", "ddim", "speaker"]
    ref = speaker_reference()
    speech = SpeechContext.of(out.job.audio, ref.mean_speed)
    for method, motion in out.motions.items():
        want = eval_motion_stats(motion, stats_body(), speech.beats, ref.mean_speed, extractors=[])
        got = shown[method]
        assert got["diversity"] == pytest.approx(want.diversity, rel=1e-5)
        for k in ("raised_share", "height_p95", "wrist_speed", "hand_spread", "jerk"):
            assert got[k] == pytest.approx(want.amplitude[k], rel=1e-9), (method, k)
        assert (np.isnan(got["bc"]) and np.isnan(want.bc)) or got["bc"] == pytest.approx(want.bc), method
    assert shown["speaker"] == pytest.approx(ref.statistics)
    titles = re.findall(r'<th title="([^"]+)" data-key="(\w+)"', page)
    assert [k for _, k in titles] == [s.key for s in STATISTICS] and all("Better:" in t for t, _ in titles)


def test_page_statistics_are_empty_without_motion():
    assert 'data-state="empty"' in stats_view.show(None)


@pytest.fixture(scope="module")
def page_sweep(service, speech_wav):
    h = SweepHandlers(service)
    return h, h.run(str(speech_wav), ["gesturelsm", "rectified_flow"], "1 2", "2", 2, "hand_spread", "", False,
                    progress=quiet)


def test_page_sweep_shows_the_numbers_gesturelsm_sweep_writes(page_sweep, tiny_assets, speech_wav, tmp_path):
    _, (table, plot, files, pick, state) = page_sweep
    assert main(["sweep", str(speech_wav), "--checkpoints", str(tiny_assets), "--methods", "gesturelsm",
                 "rectified_flow", "--steps", "1", "2", "--cfg", "2", "--seeds", "2", "--no-transcribe",
                 "--out", str(tmp_path / "cli")]) == 0
    cli = json.loads((tmp_path / "cli" / "sweep.json").read_text())["rows"]
    rows = re.findall(r'<tr data-method="(\w+)" data-steps="(\d+)" data-cfg="([\d.]+)">(.*?)</tr>', table)
    assert [(m, int(s), float(c)) for m, s, c, _ in rows] == [(r["method"], r["steps"], r["cfg"]) for r in cli]
    for (_, _, _, cells), want in zip(rows, cli):
        got = {k: float(v) for k, v in re.findall(r'data-key="(\w+)" data-value="([^"]+)"', cells)}
        for s in STATISTICS:
            w = want[s.key]
            assert (w is None and np.isnan(got[s.key])) or got[s.key] == pytest.approx(w, rel=1e-6), s.key
        assert got["seed_spread"] == pytest.approx(want["seed_spread"], rel=1e-6)
    assert plot.endswith("sweep.png") and sorted(p.rsplit("/", 1)[1] for p in files) == \
        ["sweep.csv", "sweep.json", "sweep.md", "sweep.png"]
    assert len(pick["choices"]) == 8 and pick["value"] == "0"
    assert "Measured on raw motion, not the finished motion: grounded, unsmoothed." in table    # what it measured


def test_a_sweep_run_opens_in_the_player_as_its_own_motion(page_sweep):
    from gesturelsm.export.player_payload import read_motion, motion_arrays

    h, (*_, state) = page_sweep
    payload = h.open_run(state, "5")
    run = state.result.runs[5]
    assert [b["method"] for b in payload["bodies"]] == [run.method] and payload["frames"] == run.motion.num_frames
    b = payload["bodies"][0]
    got = read_motion(b["motion"].split("file=", 1)[1]).rotations
    want = motion_arrays(run.motion, h.service.body)["rotations"]
    np.testing.assert_allclose(got, want, atol=1e-6)


def test_a_new_statistic_replots_without_generating(page_sweep):
    h, (*_, state) = page_sweep
    n = len(state.result.runs)
    path = h.replot(state, "jerk")
    assert path.endswith("sweep-jerk.png") and open(path, "rb").read(4) == b"\x89PNG" and len(state.result.runs) == n


@pytest.mark.parametrize("args, message", [
    (("", "2", 1), "Steps is empty: give at least one."),
    (("1 40", "2", 1), "Steps must be from 1 to 32 (got 40)."),           # the server's cap, as for Generate
    (("1 200", "2", 1), "Steps must be from 1 to 32 (got 200)."),
    (("1", "11", 1), "CFG scale must be between 0 and"),
    (("1 2 3 4 5 6 7", "0 1 2 3 4 5", 1), "a sweep takes at most 36"),
    (("1", "2", 5), "Seeds must be from 1 to 3"),
])
def test_bad_sweeps_are_refused_with_one_clear_message(service, speech_wav, args, message):
    steps, cfg, seeds = args
    with pytest.raises(gr.Error, match=re.escape(message)):
        SweepHandlers(service).run(str(speech_wav), ["gesturelsm"], steps, cfg, seeds, "bc", "", False,
                                   progress=quiet)


def test_a_sweep_on_silence_or_without_speech_is_refused(service, tmp_path):
    silent = tmp_path / "silence.wav"
    sf.write(silent, np.zeros(32000, np.float32), 16000)
    with pytest.raises(gr.Error, match="silent"):
        SweepHandlers(service).run(str(silent), ["gesturelsm"], "1", "2", 1, "bc", "", progress=quiet)
    with pytest.raises(gr.Error, match="upload speech"):
        SweepHandlers(service).run(None, ["gesturelsm"], "1", "2", 1, "bc", "", progress=quiet)


def test_cancel_stops_the_sweep_before_its_next_motion(service, speech_wav):
    h = SweepHandlers(service)
    calls = []

    def progress(f, desc=""):
        calls.append(desc)
        if desc.startswith("1/3 motions"):       # motion 1 is done, motion 2 is next: cancel now
            h.cancel(None)

    before = set(service.workdir.glob("req-*"))
    with pytest.raises(gr.Error, match="cancelled"):
        h.run(str(speech_wav), ["gesturelsm"], "1 2 3", "0", 1, "bc", "", False, progress=progress)
    assert any(c.startswith("1/3 motions") for c in calls)
    assert not any(c.startswith(("2/3", "3/3")) for c in calls) and set(service.workdir.glob("req-*")) == before


def test_bad_sweeps_are_refused_like_generate_all_problems_at_once(service, speech_wav):
    """The sweep takes a request's checks (GestureService.check): the upload and every field in one message."""
    with pytest.raises(gr.Error) as err:
        SweepHandlers(service).run(None, ["gesturelsm", "magic"], "0", "x", 9, "bc", "", progress=quiet)
    assert err.value.message.splitlines() == [
        "Please record or upload speech first (any common audio format).",
        "Unknown method 'magic'; available: gesturelsm, rectified_flow, ddim.", "Steps must be from 1 to 32 (got 0).",
        "CFG scale must be numbers (got 'x').", "Seeds must be from 1 to 3 (got 9)."]


def test_the_sweep_tab_transcribes_the_speech_as_generate_does(service, speech_wav, hears_hello, tmp_path):
    wav = tmp_path / "heard.wav"            # an upload of its own: the service reuses what it prepared for a file
    shutil.copyfile(speech_wav, wav)
    out = service.run(Request(str(wav), methods=("gesturelsm",), steps=1, render=False, exports=False))
    *_, state = SweepHandlers(service).run(str(wav), ["gesturelsm"], "1", "2", 1, "bc", "", progress=quiet)
    assert out.text_mode.startswith("automatic transcript (2 words") and state.result.text_mode == out.text_mode


def test_statistics_follow_the_motion_beside_the_player_and_video_chain(service):
    from gesturelsm.webapp.ui import build_demo

    demo = build_demo(service)
    deps = {d.get("api_name"): d for d in demo.blocks.get_config_file()["dependencies"]}
    gen, stats = deps["generate_motion"], deps["motion_stats"]
    # every payload handed to the player (Generate's, as methods are made; an edit's; an undo's) triggers the
    # statistics at once, beside the player's step, not chained after the video or before the player
    (payload, event), = stats["targets"]
    assert event == "change" and payload in gen["outputs"] and stats["trigger_after"] is None
    player = [d for d in deps.values() if d["targets"] == stats["targets"] and d.get("js")
              and "gesturelsmPlayer" in d["js"]]
    assert len(player) == 1
    assert deps["edit_motion"]["outputs"][0] == payload                   # an edit hands the player a payload too
    fns = demo.blocks.fns
    pools = {f.api_name: f.concurrency_id for f in (fns.values() if isinstance(fns, dict) else fns)}
    assert pools["motion_stats"] == "stats" and pools["sweep"] == "generation"


def test_the_sweep_tab_hears_the_speech_in_the_language_chosen(service, speech_wav, monkeypatch, tmp_path):
    """`#sweep-language` (as Generate's `#language`) reaches the recogniser; a language it does not know is refused
    with the Generate tab's one line, before any work."""
    from types import SimpleNamespace

    import gesturelsm.pipeline as pipeline
    from gesturelsm.align import Word
    from gesturelsm.asr.source import AutomaticWords

    heard = []

    def hear(audio, remember=True, language="auto"):
        heard.append(language)
        return AutomaticWords([Word("hola", 0.3, 0.7), Word("amigos", 0.8, 1.3)], "automatic transcript (2 words "
                              "recognised in Spanish (chosen), word timings: test)",
                              SimpleNamespace(text="hola amigos"))
    monkeypatch.setattr(pipeline, "automatic_words", hear)
    wav = tmp_path / "spanish.wav"          # an upload of its own: the service reuses what it prepared for a file
    shutil.copyfile(speech_wav, wav)
    *_, state = SweepHandlers(service).run(str(wav), ["gesturelsm"], "1", "2", 1, "bc", "", True, "es",
                                           progress=quiet)
    assert heard == ["es"] and "in Spanish" in state.result.text_mode
    with pytest.raises(gr.Error, match=re.escape("Language must be auto or a language code")):
        SweepHandlers(service).run(str(wav), ["gesturelsm"], "1", "2", 1, "bc", "", True, "klingon", progress=quiet)
    assert heard == ["es"]


def test_the_sweep_tab_offers_the_generate_tabs_languages(service):
    from gesturelsm.webapp.ui import build_demo

    demo = build_demo(service)
    config = demo.blocks.get_config_file()
    by_elem = {c["props"].get("elem_id"): c for c in config["components"] if c["props"].get("elem_id")}
    generate, sweep = by_elem["language"], by_elem["sweep-language"]
    assert sweep["props"]["choices"] == generate["props"]["choices"] and len(generate["props"]["choices"]) > 90
    assert sweep["props"]["value"] == generate["props"]["value"] == "auto"
    deps = {d.get("api_name"): d for d in config["dependencies"]}
    assert deps["sweep"]["inputs"][-1] == sweep["id"]
