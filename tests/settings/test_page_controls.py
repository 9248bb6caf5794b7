"""The page's setting controls are made from the settings object's fields (`gesturelsm.settings.controls.Control`,
`gesturelsm.webapp.controls`): their element ids, labels, info lines, bounds and kinds are the fields', so a field
whose control says otherwise changes the page's control, and the page's contracts (element ids, labels) hold."""
from __future__ import annotations

from types import SimpleNamespace

import pytest

gr = pytest.importorskip("gradio")


def _fake_service(methods=("gesturelsm", "rectified_flow", "ddim")):
    from gesturelsm.settings import Limits

    return SimpleNamespace(methods=list(methods), pipeline=SimpleNamespace(methods=list(methods)),
                           limits=Limits(step_caps={"steps": 32, "ddim_steps": 100}))


def _page_inputs(service) -> dict:
    from gesturelsm.settings import page_params
    from gesturelsm.webapp.ui import _input_column

    with gr.Blocks():
        inputs, *_ = _input_column(service)
    return dict(zip(page_params(), inputs))


def test_every_setting_has_a_control_of_a_known_kind():
    from gesturelsm.settings import settings_of
    from gesturelsm.settings.controls import KINDS, Control

    for s in settings_of():
        assert isinstance(s.page_control, Control) and s.page_control.kind in KINDS
    with pytest.raises(ValueError, match="kind"):
        Control("knob")


def test_the_page_keeps_its_controls():
    """The contracts: element ids, labels, kinds, bounds of the Generate column's settings."""
    from gesturelsm.backends import SPECS

    c = _page_inputs(_fake_service())
    assert (c["methods"].elem_id, c["auto_text"].elem_id, c["grounding"].elem_id, c["language"].elem_id) == \
        ("methods", "auto-transcribe", "grounding", "language")
    assert c["methods"].label == "Methods shown side by side" and c["methods"].value == \
        ["gesturelsm", "rectified_flow", "ddim"]
    assert c["auto_text"].label == "Transcribe automatically when no transcript is given"
    assert c["grounding"].label == "Feet on the ground (planted feet, no drift, on the floor)"
    assert c["in_place"].label == "Stand in place (no horizontal root movement)" and c["in_place"].elem_id is None
    assert c["language"].label == "Speech language"
    assert c["language"].choices[0] == ("Automatic (English first)", "auto")
    assert isinstance(c["cfg"], gr.Slider) and (c["cfg"].minimum, c["cfg"].step, c["cfg"].label) == (0.0, 0.1,
                                                                                                     "CFG scale")
    assert c["cfg"].maximum == min(SPECS[m].max_cfg for m in ("gesturelsm", "rectified_flow", "ddim"))
    assert (c["steps"].label, c["steps"].maximum, c["steps"].value) == ("Steps", 32, SPECS["gesturelsm"].default_steps)
    assert c["steps"].info == "for " + ", ".join(SPECS[m].label for m in SPECS if SPECS[m].steps_setting == "steps"
                                                 and m in ("gesturelsm", "rectified_flow"))
    assert (c["ddim_steps"].label, c["ddim_steps"].maximum, c["ddim_steps"].info) == ("DDIM steps", 100, "for DDIM")
    assert isinstance(c["seed"], gr.Number) and c["seed"].precision == 0 and c["seed"].label == "Seed"
    assert isinstance(c["smoothing"], gr.Radio) and c["smoothing"].label == "Smoothing"
    for name in ("methods", "steps", "cfg", "seed", "ddim_steps", "in_place", "smoothing", "auto_text",
                 "grounding", "language"):
        assert c[name].preprocess.__name__ == "_unchanged", name     # values reach the validator as sent


def test_a_fields_control_reaches_the_page(monkeypatch):
    """Another element id, info, bounds and step said on the seed's and the smoothing's fields are the page's."""
    import dataclasses

    from gesturelsm.constants import SMOOTHING_WINDOWS
    from gesturelsm.settings import PostProcess, Settings
    from gesturelsm.settings.controls import Control

    seed = next(f for f in dataclasses.fields(Settings) if f.name == "seed").metadata["setting"]
    smoothing = next(f for f in dataclasses.fields(PostProcess) if f.name == "smoothing").metadata["setting"]
    monkeypatch.setitem(seed, "control", Control("slider", "seed-box", info="any seed", step=1,
                                                 bounds=lambda offer: (0, 99)))
    monkeypatch.setitem(smoothing, "control", Control("dropdown", "smoothing-box", label="Smoothing window",
                                                      info="frames"))
    c = _page_inputs(_fake_service())
    assert isinstance(c["seed"], gr.Slider)
    assert (c["seed"].elem_id, c["seed"].info, c["seed"].maximum, c["seed"].label) == ("seed-box", "any seed", 99,
                                                                                       "Seed")
    assert isinstance(c["smoothing"], gr.Dropdown)
    assert (c["smoothing"].elem_id, c["smoothing"].label, c["smoothing"].info) == ("smoothing-box",
                                                                                   "Smoothing window", "frames")
    assert [v for _, v in c["smoothing"].choices] == list(SMOOTHING_WINDOWS)      # the flag's choices


def test_the_controls_follow_the_methods_a_server_loads():
    """The step sliders, the CFG bound and the methods' notes follow the server's methods (their specs)."""
    from gesturelsm.backends import SPECS

    c = _page_inputs(_fake_service(("ddim",)))
    assert c["methods"].value == ["ddim"] and [v for _, v in c["methods"].choices] == ["ddim"]
    assert c["cfg"].maximum == SPECS["ddim"].max_cfg
    assert c["ddim_steps"].info == "for DDIM"
