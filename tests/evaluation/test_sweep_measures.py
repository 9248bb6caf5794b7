"""A sweep's table says what it measured (`evaluation.sweep.MEASURES`): the raw motion as the method sampled it, not
the finished motion, grounded or not, unsmoothed; the same words in sweep.md (what `gesturelsm sweep` prints),
sweep.json and the page's Sweep table."""
from __future__ import annotations

import pytest

from gesturelsm.evaluation.motion_stats import STATISTICS
from gesturelsm.evaluation.sweep import SweepGrid, SweepResult, SweepRun
from gesturelsm.evaluation.sweep_limits import MEASURES, measures
from gesturelsm.evaluation.sweep_report import markdown_text, sweep_json


def _result(grounding: bool) -> SweepResult:
    run = SweepRun("gesturelsm", 1, 2.0, 0, 0.1, {s.key: 0.5 for s in STATISTICS})
    return SweepResult(SweepGrid(("gesturelsm",), (1,), (2.0,), 1), [run], 2.0, "audio only", None, 1.0, 0.1,
                       grounding)


@pytest.mark.parametrize("grounding, said", [(True, "grounded"), (False, "not grounded")])
def test_the_sweep_table_says_it_measures_raw_unsmoothed_motion(grounding, said):
    statement = f"raw motion, not the finished motion: {said}, unsmoothed"
    assert measures(grounding) == statement == MEASURES.format(grounded=said)
    result = _result(grounding)
    assert markdown_text(result).splitlines()[0] == f"Measured on {statement}."
    assert sweep_json(result)["measures"] == statement
    pytest.importorskip("gradio")
    from gesturelsm.webapp.sweep_tab import table_html

    assert f'<span class="sweep-measures">Measured on {statement}.</span>' in table_html(result)
