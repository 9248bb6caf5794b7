"""The settings of one generation with the defaults every entry point shows (the page's controls, the CLI's flags and
their `--help`, the Gradio API, the study batch), and the limits an entry point adds to the methods' own bounds.

    Settings(methods=("gesturelsm", "ddim"), steps={"ddim": 40}, cfg=2.0, seed=0,
             post=PostProcess(stand_in_place=False, smoothing="light"))

A method missing from `steps` runs its spec's default steps (`gesturelsm.backends.SPECS`); every value is checked by
`gesturelsm.settings.check` before a settings object is made from what a person sent. Each field says what it is to
every entry point (`fields.setting`: its label, flag, page parameter, check, whether it changes the motion); the
flags, the validator, the page's and the API's parameters, the request and the made-ahead key are made from that.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Mapping

from ..asr.languages import AUTO, LANGUAGES
from ..constants import DEFAULT_SMOOTHING, MAX_SECONDS, SMOOTHING_WINDOWS
from .controls import (Control, cfg_range, method_choices, methods_info, methods_shown, step_info, step_range,
                       step_value)
from .fields import Setting, setting
from .values import check_language, choice, from_text, switch, whole_in

if TYPE_CHECKING:           # the settings load no torch: the methods' registry and the motion code on first use
    from ..backends import MethodSpec
    from ..motion.sequence import MotionSequence

DEFAULT_METHOD = "gesturelsm"        # the method a command runs when none is named
DEFAULT_CFG = 2.0                    # the paper's guidance scale
SEED_MAX = 2 ** 32 - 1               # numpy's and torch's seed range
MIN_SECONDS = 0.5                    # shorter speech has no gesture to follow


def _steps_control(setting: str) -> Control:
    """A step slider: up to the most steps the server accepts for the methods it drives, at the first one's default."""
    return Control("slider", step=1, bounds=step_range(setting), value=step_value(setting), info=step_info(setting))


# the page's second step slider (the diffusion methods'): checked into `Settings.steps` with --steps / "Steps"
DDIM_STEPS = Setting("ddim_steps", "DDIM steps", "--ddim-steps", "ddim_steps", page=7, cli=None, merged=True,
                     control=_steps_control("ddim_steps"))
LANGUAGE_CHOICES = [("Automatic (English first)", AUTO), *((f"{n} ({c})", c) for c, n in LANGUAGES.items())]


@dataclass(frozen=True)
class PostProcess:
    """What is done to every finished motion, each method's and ground truth's alike: stand in place, then smoothing
    (`motion/postprocess.py`), then feet on the ground (`gesturelsm.grounding`). With stand in place and grounding
    both on, the root stays on the spot horizontally and the legs plant the feet under it."""
    stand_in_place: bool = setting(False, label="Stand in place", flag="--stand-in-place", param="in_place", page=8,
                                   check=switch, cli="post", help="remove horizontal root movement",
                                   argparse={"action": "store_true"},
                                   control=Control("checkbox", label="Stand in place (no horizontal root movement)"))
    smoothing: str = setting(DEFAULT_SMOOTHING, label="Smoothing", flag="--smoothing", param="smoothing", page=9,
                             check=choice(SMOOTHING_WINDOWS), cli="post", argparse={"choices": list(SMOOTHING_WINDOWS)},
                             control=Control("radio"),
                             help="smoothing of the finished motion (a Savitzky-Golay filter over 0 / 5 / 9 / 15 "
                                  "frames); 'off' writes the raw model output (default: {default})")
    grounding: bool = setting(True, label="Feet on the ground", flag="--grounding", param="grounding", page=12,
                              check=switch, cli="post", argparse={"choices": ["on", "off"], "default": "on"},
                              from_cli=lambda v: v == "on",
                              control=Control("checkbox", "grounding",
                                              label="Feet on the ground (planted feet, no drift, on the floor)"),
                              help="feet on the ground: planted feet, no drift, the body on the floor "
                                   "(docs/GROUNDING.md); 'off' keeps the decoder's root and legs")

    def apply(self, motion: MotionSequence, body=None) -> tuple[MotionSequence, str | None]:
        """The motion post-processed (grounded on `body`, default the mannequin or $GESTURELSM_SMPLX_MODEL), and why
        grounding had to leave it as it was, when it had to (one sentence)."""
        from ..grounding import ground_motion
        from ..motion.postprocess import postprocess

        motion = postprocess(motion, self.stand_in_place, self.smoothing)
        if not self.grounding:
            return motion, None
        res = ground_motion(motion, body)
        return res.motion, res.warning


@dataclass(frozen=True)
class Settings:
    """One generation's settings: which methods, their steps, guidance, seed, post-processing, transcription and the
    speech's language."""
    methods: tuple[str, ...] = setting((DEFAULT_METHOD,), label="Methods", flag="--methods", param="methods", page=3,
                                       cli="methods", argparse={"nargs": "+"},
                                       help="default: every generator found",   # method keys and/or GROUND_TRUTH
                                       control=Control("checkboxes", "methods", label="Methods shown side by side",
                                                       info=methods_info, value=methods_shown, choices=method_choices))
    steps: Mapping[str, int] = setting(factory=dict, label="Steps", flag="--steps", param="steps", page=4, cli=None,
                                       also=(DDIM_STEPS,), control=_steps_control("steps"))
    # steps per method; a method missing takes its spec's default_steps
    cfg: float = setting(DEFAULT_CFG, label="CFG scale", flag="--cfg", param="cfg", page=5,
                         argparse={"type": from_text}, help="classifier-free guidance scale (default: {default:g})",
                         control=Control("slider", step=0.1, bounds=cfg_range))
    seed: int = setting(0, label="Seed", flag="--seed", param="seed", page=6, check=whole_in(0, SEED_MAX),
                        argparse={"type": from_text},
                        help="generation seed: the same seed gives the same motion (default: {default})",
                        control=Control("number", precision=0))
    post: PostProcess = PostProcess()
    transcribe: bool = setting(True, label="Automatic transcription", flag="--no-transcribe", param="auto_text",
                               page=11, check=switch, cli="transcribe", from_cli=lambda v: not v,
                               argparse={"action": "store_true", "default": False},
                               help="audio-only: do not transcribe the speech",
                               control=Control("checkbox", "auto-transcribe",
                                               label="Transcribe automatically when no transcript is given"))
    # recognise the speech when neither a transcript nor word timings are given
    language: str = setting(AUTO, label="Language", flag="--language", param="language", page=13, check=check_language,
                            cli="language", argparse={"metavar": "CODE"},
                            control=Control("dropdown", "language", label="Speech language", choices=LANGUAGE_CHOICES),
                            help="the speech's language: auto (English first, else the language the multilingual "
                                 f"recogniser identifies) or one of {' '.join(LANGUAGES)} (default: {{default}})")
    # the speech's language (asr.languages.CHOICES): AUTO hears English first

    def steps_for(self, method: str) -> int:
        from ..backends import method_spec

        return int(self.steps.get(method, method_spec(method).default_steps))

    def one_call(self) -> tuple[str, int, float, int, bool, PostProcess, str]:
        """(method, its steps, CFG, seed, transcribe, post-processing, language) of the first method: what one
        method's call takes (`GesturePipeline.edit`)."""
        method = self.methods[0]
        return method, self.steps_for(method), self.cfg, self.seed, self.transcribe, self.post, self.language

    @property
    def generators(self) -> list[str]:
        """The chosen methods that generate (ground truth is looked up, not generated)."""
        from ..backends import GROUND_TRUTH

        return [m for m in dict.fromkeys(self.methods) if m != GROUND_TRUTH]


DEFAULTS = Settings()


@dataclass(frozen=True)
class Limits:
    """What an entry point accepts beyond each method's own bounds: the longest speech, and at most this many steps
    per step setting ({"steps": 32, "ddim_steps": 100} on the web server; none on the command line)."""
    max_seconds: float = MAX_SECONDS
    step_caps: Mapping[str, int] = field(default_factory=dict)

    def max_steps(self, spec: MethodSpec) -> int:
        return min(spec.max_steps, self.step_caps.get(spec.steps_setting, spec.max_steps))


__all__ = ["DEFAULTS", "DEFAULT_CFG", "DEFAULT_METHOD", "Limits", "MAX_SECONDS", "MIN_SECONDS", "PostProcess",
           "SEED_MAX", "Settings"]
