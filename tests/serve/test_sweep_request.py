"""A sweep's request takes its settings part from the settings object (`evaluation.sweep_limits.sweep_settings`: every
setting but those its grid varies and those its measurement fixes), each checked by the one validator: the same
line for the same bad value as Generate (`serve.checks.check_request`) and `gesturelsm generate`."""
from __future__ import annotations

import dataclasses

import pytest

from gesturelsm.cli import main
from gesturelsm.evaluation.sweep import SweepLimits
from gesturelsm.evaluation.sweep_limits import MEASURED_POST, SWEPT, sweep_settings
from gesturelsm.serve.checks import check_request
from gesturelsm.serve.request import VIDEO_SIZES, Request
from gesturelsm.serve.sweep import SweepRequest, checked_sweep
from gesturelsm.settings import DEFAULTS, Limits, settings_of

AVAILABLE = ["gesturelsm", "rectified_flow", "ddim"]


def test_the_sweep_request_has_a_field_per_setting_it_takes():
    names = [s.name for s in sweep_settings()]
    assert names == ["methods", "grounding", "transcribe", "language"]
    assert set(names) | set(SWEPT) | set(MEASURED_POST) == {s.name for s in settings_of()}
    fields = {f.name: f.default for f in dataclasses.fields(SweepRequest)}
    assert list(fields)[:7] == ["audio_path", "methods", "steps", "cfgs", "seeds", "metric", "text"]
    assert (fields["grounding"], fields["transcribe"], fields["language"]) == \
        (DEFAULTS.post.grounding, DEFAULTS.transcribe, DEFAULTS.language)


def test_a_good_sweep_request_gives_its_settings_part_and_grid():
    problems: list[str] = []
    req = SweepRequest("a.wav", ["ddim", "gesturelsm"], "1 2", "2 3", 2, "bc", grounding=False, language=" EN ")
    part, grid, metric = checked_sweep(req, AVAILABLE, SweepLimits(), Limits(), problems)
    assert problems == [] and metric == "bc"
    assert part == {"methods": ("ddim", "gesturelsm"), "grounding": False, "transcribe": True, "language": "en"}
    assert (grid.methods, grid.steps, grid.cfgs, grid.seeds) == (("ddim", "gesturelsm"), (1, 2), (2.0, 3.0), 2)


@pytest.mark.parametrize("bad", [dict(transcribe="yes"), dict(language="xx"), dict(grounding="maybe"),
                                 dict(methods=["magic"]), dict(methods=[]), dict(methods="gesturelsm"),
                                 dict(language=None, grounding=1)])
def test_a_bad_setting_is_refused_with_generates_line(bad):
    """The same values sent to Generate and to the Sweep tab give the same lines, once each."""
    methods = bad.pop("methods", ["gesturelsm"])
    problems: list[str] = []
    checked_sweep(SweepRequest("a.wav", methods, "1", "2", 1, "bc", **bad), AVAILABLE, SweepLimits(), Limits(),
                  problems)
    generate = check_request(Request("a.wav", methods=methods, **bad), AVAILABLE, Limits(), VIDEO_SIZES)[2]
    assert problems == generate and problems


def test_the_sweep_command_refuses_a_bad_language_as_generate_does(tmp_path, capsys):
    lines = []
    for command in ("generate", "sweep"):
        rc = main([command, str(tmp_path / "missing.wav"), "--language", "xx", "--out", str(tmp_path / "out")])
        lines.append({line.removeprefix(f"gesturelsm {command}: error: ")
                      for line in capsys.readouterr().err.splitlines()})
        assert rc == 2
    said = {line for line in lines[0] & lines[1] if "--language" in line}
    assert len(said) == 1, lines
