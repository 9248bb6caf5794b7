"""Each setting is said once, on its field of the settings object (`gesturelsm.settings.fields`): a field added there
appears in the command line, the validator, the request, the sweep's request, the page's controls and handlers, the
Gradio API and the key of motion made ahead, with no other edit, and a field's control (kind, element id, info,
bounds) is the page's. The added field runs in a process of its own, the settings object replaced by one with the
field before anything else is imported (as if the field were written in defaults.py)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

ADDED = r'''
import argparse, dataclasses, inspect
from types import SimpleNamespace

from gesturelsm.settings import schema
from gesturelsm.settings.controls import Control
from gesturelsm.settings.defaults import DEFAULT_CFG, Settings
from gesturelsm.settings.fields import setting
from gesturelsm.settings.values import from_text, real_number


@dataclasses.dataclass(frozen=True)
class WithEnergy(Settings):
    # an existing field whose control says other bounds, step and info: the page's CFG slider follows it
    cfg: float = setting(DEFAULT_CFG, label="CFG scale", flag="--cfg", param="cfg", page=5,
                         argparse={"type": from_text}, help="classifier-free guidance scale (default: {default:g})",
                         control=Control("slider", "cfg-box", info="guidance, retold", step=0.5,
                                         bounds=lambda offer: (0.5, 9.0)))
    energy: float = setting(1.0, label="Energy", flag="--energy", param="energy",
                            check=lambda v, f, p: real_number(v, f, 0.0, 3.0, p), argparse={"type": from_text},
                            help="how much the body moves (default: {default:g})",
                            control=Control("slider", "energy", info="how much the body moves", step=0.25,
                                            bounds=lambda offer: (0.0, 3.0)))


schema.Settings = WithEnergy                 # the shipped settings object, with the field added

from gesturelsm.cli import build_parser
from gesturelsm.serve.ahead import motion_key
from gesturelsm.serve.checks import check_request
from gesturelsm.serve.request import Request
from gesturelsm.settings import CLI, PAGE, Asked, Limits, Plan, checked, page_params, settings_problems
from gesturelsm.settings.arguments import cli_settings

# the command line: the flag with its help and default, read into the settings by the one validator
parser = build_parser("generate")
gen = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices["generate"]
assert "--energy" in gen.format_help() and "how much the body moves (default: 1)" in gen.format_help()
args = parser.parse_args(["generate", "a.wav", "--out", "x.npz", "--energy", "2.5"])
problems = []
assert cli_settings(args, [args.method], problems).energy == 2.5 and problems == []
bad = parser.parse_args(["generate", "a.wav", "--out", "x.npz", "--energy", "9"])
cli_settings(bad, [bad.method], problems)
assert problems == ["--energy must be between 0 and 3 (got 9)."], problems

# the validator: its default, its check, named as each entry point names it
assert checked(Asked(), ["gesturelsm"]).energy == 1.0
page = settings_problems(Asked(energy="x"), ["gesturelsm"], names=PAGE)[1]
assert page == ["Energy must be a number from 0 to 3 (got 'x')."], page
cli = settings_problems(Asked(energy=-1), ["gesturelsm"], names=CLI)[1]
assert cli == ["--energy must be between 0 and 3 (got -1)."], cli

# the request: a field of its own, checked by name
req = Request("a.wav", energy=0.5)
assert check_request(req, ["gesturelsm"], Limits(), [256, 384])[1].energy == 0.5
assert "Energy" in check_request(Request("a.wav", energy=7), ["gesturelsm"], Limits(), [256, 384])[2][0]

# the sweep's request: a field of its own, checked by the one validator with Generate's words
from gesturelsm.evaluation.sweep import SweepLimits
from gesturelsm.serve.sweep import SweepRequest, checked_sweep

assert [f.name for f in dataclasses.fields(SweepRequest)][-1] == "energy"
problems = []
checked_sweep(SweepRequest("a.wav", ["gesturelsm"], "1", "2", 1, "bc", energy=7), ["gesturelsm"], SweepLimits(),
              Limits(), problems)
assert problems == ["Energy must be between 0 and 3 (got 7)."], problems

# the made-ahead key: motion made with another energy is not taken
one, two = (Plan(checked(Asked(energy=e), ["gesturelsm"])) for e in (1.0, 2.0))
assert motion_key("upload", "speech", one) != motion_key("upload", "speech", two)
assert motion_key("upload", "speech", one) == motion_key("upload", "speech", Plan(checked(Asked(), ["gesturelsm"])))

# the page: the handlers' and the API's parameter, optional with its default, and a control of its own
import gradio as gr
from gesturelsm.backends import SPECS
from gesturelsm.webapp.ui import _Handlers, _input_column

assert page_params()[-1] == "energy"
for handler in (_Handlers.show_motion, _Handlers.generate, _Handlers.prefetch):
    assert inspect.signature(handler).parameters["energy"].default == 1.0
sent = dict.fromkeys(page_params()) | {"audio": "a.wav", "energy": 2.0}
assert _Handlers.request(sent, exports=False).energy == 2.0
fake = SimpleNamespace(methods=["gesturelsm"], pipeline=SimpleNamespace(methods=["gesturelsm"]), limits=Limits())
h = _Handlers.__new__(_Handlers)
with gr.Blocks() as demo:
    inputs, button, _, _ = _input_column(fake)
    button.click(h.generate, inputs, gr.JSON(), api_name="generate")
assert inputs[-1].label == "Energy" and inputs[-1].value == 1.0 and isinstance(inputs[-1], gr.Slider)
assert (inputs[-1].elem_id, inputs[-1].info, inputs[-1].maximum, inputs[-1].step) == \
    ("energy", "how much the body moves", 3.0, 0.25)
cfg = inputs[page_params().index("cfg")]
assert (cfg.elem_id, cfg.info, cfg.minimum, cfg.maximum, cfg.step) == ("cfg-box", "guidance, retold", 0.5, 9.0, 0.5)
api = demo.get_api_info()["named_endpoints"]["/generate"]["parameters"]
assert [p["parameter_name"] for p in api] == list(page_params())
assert api[-1]["parameter_has_default"] and api[-1]["parameter_default"] == 1.0
print("every entry point has it")
'''


@pytest.mark.slow
def test_a_field_added_to_the_settings_object_appears_everywhere():
    env = {**os.environ, "PYTHONPATH": str(ROOT), "GRADIO_ANALYTICS_ENABLED": "False"}
    run = subprocess.run([sys.executable, "-c", ADDED], capture_output=True, text=True, env=env, cwd=ROOT,
                         timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    assert "every entry point has it" in run.stdout


def test_the_page_and_the_api_keep_their_parameters():
    """The handlers' and the API's parameter names and order, made from the settings object, are the contract."""
    from gesturelsm.settings import page_params

    assert page_params() == ("audio", "text", "textgrid", "methods", "steps", "cfg", "seed", "ddim_steps",
                             "in_place", "smoothing", "size", "auto_text", "grounding", "language")


def test_names_flags_and_the_made_ahead_values_come_from_the_fields():
    from gesturelsm.settings import CLI, DEFAULTS, PAGE, PostProcess, motion_values, settings_of

    assert [(s.name, PAGE.of(s), CLI.of(s)) for s in settings_of()] == [
        ("methods", "Methods", "--methods"), ("steps", "Steps", "--steps"),
        ("ddim_steps", "DDIM steps", "--ddim-steps"), ("cfg", "CFG scale", "--cfg"), ("seed", "Seed", "--seed"),
        ("stand_in_place", "Stand in place", "--stand-in-place"),
        ("smoothing", "Smoothing", "--smoothing"), ("grounding", "Feet on the ground", "--grounding"),
        ("transcribe", "Automatic transcription", "--no-transcribe"), ("language", "Language", "--language")]
    assert PAGE.ddim_steps == "DDIM steps" and CLI.transcribe == "--no-transcribe"
    moved = DEFAULTS.__class__(post=PostProcess(smoothing="off"))
    assert motion_values(DEFAULTS) != motion_values(moved)
    assert dict(motion_values(DEFAULTS))["steps"] == () and dict(motion_values(moved))["smoothing"] == "off"
