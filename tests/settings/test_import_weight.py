"""`import gesturelsm.settings` loads no torch (nor the methods' registry, the motion code or grounding): a command
line, a page or a script that only checks settings starts without the model stack. The registry is loaded on first
use, and the settings then give what they gave with it loaded up front."""
from __future__ import annotations

import subprocess
import sys


def _loaded_after(statement: str) -> set[str]:
    code = f"import sys\n{statement}\nprint(' '.join(sorted(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    return set(out.split())


def test_importing_the_settings_loads_no_torch():
    loaded = _loaded_after("import gesturelsm.settings")
    assert "torch" not in loaded
    assert not {m for m in loaded if m.startswith(("gesturelsm.backends", "gesturelsm.motion", "gesturelsm.grounding"))}


def test_the_registry_is_read_on_first_use():
    from gesturelsm.backends import GROUND_TRUTH, SPECS
    from gesturelsm.constants import DEFAULT_SMOOTHING, SMOOTHING_WINDOWS
    from gesturelsm.motion import postprocess
    from gesturelsm.settings import DEFAULTS, PAGE, Asked, Settings, settings_problems

    assert (postprocess.SMOOTHING_WINDOWS, postprocess.DEFAULT_SMOOTHING) == (SMOOTHING_WINDOWS, DEFAULT_SMOOTHING)
    assert DEFAULTS.steps_for("ddim") == SPECS["ddim"].default_steps
    assert Settings(methods=(GROUND_TRUTH, "ddim", "ddim")).generators == ["ddim"]
    high = SPECS["ddim"].max_steps
    assert settings_problems(Asked(methods=["ddim"], steps=high + 1), [*SPECS], names=PAGE) == (
        None, [f"Steps must be from 1 to {high} (got {high + 1})."])
