"""The one validator (gesturelsm/settings/check.py): which step setting drives which method, each method's own bound
and the entry point's caps, every problem once and named as the entry point names the field, and the defaults."""
from __future__ import annotations

import pytest

from gesturelsm.settings import CLI, DEFAULTS, PAGE, Asked, Limits, PostProcess, Settings, checked, settings_problems

OURS = ["gesturelsm", "rectified_flow", "ddim"]


def test_nothing_sent_gives_the_defaults():
    assert checked(Asked(), OURS) == DEFAULTS == Settings(("gesturelsm",), {}, 2.0, 0, PostProcess(False, "light"))
    assert DEFAULTS.steps_for("gesturelsm") == 8 and DEFAULTS.steps_for("ddim") == 20


@pytest.mark.parametrize("asked, steps", [
    (Asked(OURS, 4, 40), {"gesturelsm": 4, "rectified_flow": 4, "ddim": 40}),        # the page's two sliders
    (Asked(["ddim"], 50), {"ddim": 50}),                                              # one value for the chosen
    (Asked(OURS, ddim_steps=40), {"ddim": 40}),                                       # the others: their defaults
    (Asked(["gesturelsm"], {"gesturelsm": 3, "ddim": 5000}), {"gesturelsm": 3}),     # a method not chosen: ignored
])
def test_each_step_setting_drives_its_methods(asked, steps):
    assert dict(checked(asked, OURS).steps) == steps


@pytest.mark.parametrize("asked, limits, problems", [
    (Asked(["gesturelsm"], 4, float("inf")), Limits(), ["DDIM steps must be a whole number from 1 to 1000 (got inf; "
                                                        "it is not rounded for you)."]),   # sent, though unused
    (Asked(OURS, 40, 40), Limits(step_caps={"steps": 32}), ["Steps must be from 1 to 32 (got 40)."]),
    (Asked(["gesturelsm", "ddim"], 500), Limits(), ["Steps for GestureLSM must be from 1 to 128 (got 500)."]),
    (Asked(["gesturelsm", "ddim"], 0), Limits(), ["Steps must be from 1 to 1000 (got 0)."]),   # once, not per method
    (Asked(["magic"], 4, cfg=11, seed=-1, smoothing="x"), Limits(),
     ["Unknown method 'magic'; available: gesturelsm, rectified_flow, ddim.", "CFG scale must be between 0 and 10 "
      "(got 11).", "Seed must be from 0 to 4294967295 (got -1).", "Smoothing must be one of off, light, medium, "
      "strong (got 'x')."]),
])
def test_every_problem_once_against_each_methods_bound_and_the_caps(asked, limits, problems):
    assert settings_problems(asked, OURS, limits) == (None, problems)


def test_fields_are_named_as_the_entry_point_names_them():
    _, page = settings_problems(Asked(["gesturelsm"], 0, cfg=-1), OURS, names=PAGE)
    _, cli = settings_problems(Asked(["gesturelsm"], 0, cfg=-1), OURS, names=CLI)
    assert [p.split()[0] for p in page] == ["Steps", "CFG"] and [p.split()[0] for p in cli] == ["--steps", "--cfg"]
