"""What the package says about one method, written once in its registry line (`gesturelsm.backends.BACKENDS`):
the page, the command line, the sweep, the study batch, the evaluation and the live mode read it from there.

    MethodSpec("gesturelsm", "GestureLSM", "#d62728", default_steps=8, max_steps=Shortcut.max_steps,
               inpainting=True)

- `label`, `color`: how people see it (page choices, tables, plots, videos).
- `default_steps`, `max_steps`, `max_cfg`: the settings it runs with when none are given and the largest accepted;
  the settings' validator (`gesturelsm.settings`) checks every entry point's values against them.
- `steps_setting`: which of the two step settings drives its steps: "steps" (the page's *Steps* slider, the CLI's
  `--steps`) or "ddim_steps" (*DDIM steps*, `--ddim-steps`), so diffusion's tens of steps and the flows' few can
  be set at once.
- `regions`: the body regions it generates; the others stay neutral (the authors' models have no face).
- `imported`: the authors' released weights (`gesturelsm import-reference`), not trained here.
- `inpainting`: its sampler can hold known latents fixed while it samples the rest (replacement inpainting: the
  known part is noised to each step's time along the method's own forward process), which editing a stretch
  of a motion needs.
What a network outputs (clean latents or a velocity) is a fact of each checkpoint, not of the method
(`GeneratorConfig.prediction`), and is not part of the spec.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..motion.regions import GENERATED_REGIONS

MAX_CFG = 10.0                      # the largest classifier-free guidance scale a method accepts unless it says
STEPS_SETTINGS = {"steps": "Steps", "ddim_steps": "DDIM steps"}     # setting -> its name on the page
GROUND_TRUTH = "ground_truth"       # a "method" of a plan: the BEAT2 take's own motion
GROUND_TRUTH_LABEL = "Ground truth"


@dataclass(frozen=True)
class Bounds:
    """The settings a method accepts: steps in [min_steps, max_steps], CFG scale in [min_cfg, max_cfg]."""
    min_steps: int
    max_steps: int
    min_cfg: float
    max_cfg: float


@dataclass(frozen=True)
class MethodSpec:
    """One method, as every part of the package sees it (see the module docstring for each field)."""
    key: str                                    # the name in checkpoints, the CLI, the API and the page
    label: str
    color: str                                  # matplotlib colour of its lines in plots
    default_steps: int
    max_steps: int
    steps_setting: str = "steps"                # "steps" | "ddim_steps"
    regions: tuple[str, ...] = GENERATED_REGIONS
    imported: bool = False
    inpainting: bool = False
    max_cfg: float = MAX_CFG

    def __post_init__(self) -> None:
        if self.steps_setting not in STEPS_SETTINGS:
            raise ValueError(f"{self.key}: steps_setting must be one of {', '.join(STEPS_SETTINGS)}")
        if not 1 <= self.default_steps <= self.max_steps:
            raise ValueError(f"{self.key}: default_steps {self.default_steps} outside 1..{self.max_steps}")

    @property
    def bounds(self) -> Bounds:
        return Bounds(1, self.max_steps, 0.0, self.max_cfg)


__all__ = ["Bounds", "GROUND_TRUTH", "GROUND_TRUTH_LABEL", "MAX_CFG", "MethodSpec", "STEPS_SETTINGS"]
