"""The settings of one generation with the defaults every entry point shows (the page's controls, the CLI's flags and
their `--help`, the Gradio API, the study batch), and the limits an entry point adds to the methods' own bounds.

    Settings(methods=("gesturelsm", "ddim"), steps={"ddim": 40}, cfg=2.0, seed=0,
             post=PostProcess(stand_in_place=False, smoothing="light"))

A method missing from `steps` runs its spec's default steps (`gesturelsm.backends.SPECS`); every value is checked by
`gesturelsm.settings.check` before a settings object is made from what a person sent.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Mapping

from ..asr.languages import AUTO
from ..constants import DEFAULT_SMOOTHING, MAX_SECONDS

if TYPE_CHECKING:           # the settings load no torch: the methods' registry and the motion code on first use
    from ..backends import MethodSpec
    from ..motion.sequence import MotionSequence

DEFAULT_METHOD = "gesturelsm"        # the method a command runs when none is named
DEFAULT_CFG = 2.0                    # the paper's guidance scale
SEED_MAX = 2 ** 32 - 1               # numpy's and torch's seed range
MIN_SECONDS = 0.5                    # shorter speech has no gesture to follow


@dataclass(frozen=True)
class PostProcess:
    """What is done to every finished motion, each method's and ground truth's alike: stand in place, then smoothing
    (`motion/postprocess.py`), then feet on the ground (`gesturelsm.grounding`). With stand in place and grounding
    both on, the root stays on the spot horizontally and the legs plant the feet under it."""
    stand_in_place: bool = False         # the root's horizontal movement removed
    smoothing: str = DEFAULT_SMOOTHING   # motion.postprocess.SMOOTHING_WINDOWS
    grounding: bool = True               # planted feet, no drift, the body on the floor (docs/GROUNDING.md)

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
    methods: tuple[str, ...] = (DEFAULT_METHOD,)     # method keys and/or GROUND_TRUTH, in the order shown
    steps: Mapping[str, int] = field(default_factory=dict)    # per method; missing: its spec's default_steps
    cfg: float = DEFAULT_CFG
    seed: int = 0
    post: PostProcess = PostProcess()
    transcribe: bool = True              # recognise the speech when neither a transcript nor word timings are given
    language: str = AUTO                 # the speech's language (asr.languages.CHOICES): AUTO hears English first

    def steps_for(self, method: str) -> int:
        from ..backends import method_spec

        return int(self.steps.get(method, method_spec(method).default_steps))

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
