"""The Edit section's events (gesturelsm/webapp/edit_section.py) over the request service: shown after Generate with
the motions that can edit, an edit becomes the page's newest request (its video and downloads are made, the
replaced request's are not), downloads follow the edited motion, Undo hands back the result before it with its own
files, and a problem is one message on the page."""
from __future__ import annotations

from types import SimpleNamespace

import gradio as gr
import numpy as np
import pytest

from _support import quiet
from gesturelsm.motion import MotionSequence
from gesturelsm.settings import PAGE, Asked, settings_problems
from gesturelsm.webapp.edit_section import EditHandlers
from gesturelsm.webapp.ui import _Handlers, build_demo


def checked_seed_message(seed) -> str:
    """What the settings' validator says of `seed` as Generate's seed."""
    return settings_problems(Asked(seed=seed), ["gesturelsm"], names=PAGE)[1][0]


def _inputs(wav) -> tuple:
    #       audio, text, textgrid, methods, steps, cfg, seed, ddim_steps, in_place, smoothing, size, auto_text
    return (str(wav), "", None, ["gesturelsm", "ddim", "ground_truth"], 2, 2.0, 0, 2, False, "light", 256, False)


def test_the_section_is_wired_with_its_element_ids(service):
    page = build_demo(service).blocks
    ids = {c.elem_id for c in page.blocks.values() if getattr(c, "elem_id", None)}
    assert {"edit-start", "edit-end", "edit-regions", "edit-run", "edit-undo", "edit-method", "edit-seed"} <= ids
    names = {f.api_name for f in (page.fns.values() if isinstance(page.fns, dict) else page.fns)}
    assert "edit_motion" in names
    seed = next(c for c in page.blocks.values() if getattr(c, "elem_id", None) == "edit-seed")
    assert seed.preprocess(1.5) == 1.5 and seed.preprocess(2**40) == 2**40   # sent as typed, for the validator


def test_edit_downloads_and_undo_through_the_page_handlers(service, speech_wav):
    h, page = _Handlers(service), SimpleNamespace(session_hash="page-e")
    e = EditHandlers(h)
    first = list(h.show_motion(*_inputs(speech_wav), request=page, progress=quiet))[-1][3]   # the button's last yield
    box, method, start, end, undo = e.ready(first)
    assert box["visible"] and method["value"] == "gesturelsm" and [c[1] for c in method["choices"]] == ["gesturelsm",
                                                                                                      "ddim"]
    assert 0 <= start < end <= first.job.speech_seconds
    payload, rows, summary, new, undo = e.run(first, "ddim", 0.5, 1.5, ["upper", "face"], 4, request=page,
                                              progress=quiet)
    assert payload["resume"] and payload["compare"]["method"] == "ddim" and undo["interactive"]
    assert rows == new.table and all(isinstance(r, list) for r in rows)      # the cells the page's table shows
    assert "**Edited:** DDIM: upper, face 0.50-1.50 s, seed 4" in summary and new.previous is first
    assert h.show_video(first, request=page, progress=quiet) == (gr.skip(),) * 4    # the edit replaced it
    video, _, _, new = h.show_video(new, request=page, progress=quiet)
    files, glb, _, new = h.add_exports(new, request=page)
    npz = next(f for f in files if f.endswith("ddim.npz"))
    assert str(new.job.folder) in npz and video.startswith(str(new.job.folder))
    assert np.array_equal(MotionSequence.load(npz).expressions, new.motions["ddim"].expressions)
    assert not np.array_equal(new.motions["ddim"].expressions, first.motions["ddim"].expressions)
    back = e.undo(new, request=page)
    assert back[3] is first and "compare" not in back[0] and not back[-1]["interactive"]
    assert back[1] == first.table
    assert back[4] is None and back[5] is None               # the first result was replaced before its video
    with pytest.raises(gr.Error, match="Nothing to undo"):
        e.undo(first, request=page)
    with pytest.raises(gr.Error, match="Choose at least one body region"):
        e.run(first, "gesturelsm", 0.5, 1.5, [], 1, request=page, progress=quiet)
    for seed in (1.5, 2**40):               # the settings' validator's message, as Generate's seed gets it
        with pytest.raises(gr.Error) as refused:
            e.run(first, "gesturelsm", 0.5, 1.5, ["upper"], seed, request=page, progress=quiet)
        assert refused.value.message == checked_seed_message(seed)


def test_gradio_hands_the_edit_events_the_page_session():
    from gradio.helpers import special_args

    e, page = EditHandlers.__new__(EditHandlers), SimpleNamespace(session_hash="page-1")
    for fn, n_inputs, progress in ((e.run, 7, True), (e.undo, 2, False)):
        filled, progress_at, _, _ = special_args(fn, list(range(n_inputs)), request=page)
        assert filled[n_inputs] is page and progress_at == (n_inputs + 1 if progress else None)
