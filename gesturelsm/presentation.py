"""How methods are shown to people, keyed by method key: labels (page, tables, plots), plot colours, and which
of the page's and the CLI's two step settings drives a method's steps. The maths (bounds, defaults, what a
method predicts) is in the backend registry (`gesturelsm.backends`); nothing here changes what is generated.
"""
from __future__ import annotations

from typing import Any, Iterable

GROUND_TRUTH_KEY = "ground_truth"

LABELS: dict[str, str] = {
    "gesturelsm": "GestureLSM",
    "rectified_flow": "Rectified flow",
    "ddim": "DDIM",
    "gesturelsm_authors": "GestureLSM (authors' weights)",
    "meanflow_authors": "MeanFlow (authors' weights)",
    "diffusion_authors": "Diffusion (authors' weights)",
    GROUND_TRUTH_KEY: "Ground truth",
}

COLORS: dict[str, str] = {
    "gesturelsm": "#d62728",
    "rectified_flow": "#1f77b4",
    "ddim": "#2ca02c",
    "gesturelsm_authors": "#9467bd",
    "meanflow_authors": "#8c564b",
    "diffusion_authors": "#e377c2",
}

# methods whose steps the "DDIM steps" slider / `--ddim-steps` sets; every other method reads "Steps" / `--steps`
DDIM_STEPS_METHODS: frozenset[str] = frozenset({"ddim", "diffusion_authors"})


def label(key: str) -> str:
    """A method's label for people; a key with no label (a method added without one) is shown as it is."""
    return LABELS.get(key, key)


def steps_setting(key: str) -> str:
    """Which step setting drives the method: "ddim_steps" or "steps"."""
    return "ddim_steps" if key in DDIM_STEPS_METHODS else "steps"


def steps_setting_name(key: str) -> str:
    """The setting's name as the page shows it ("DDIM steps" or "Steps"), for messages about its value."""
    return "DDIM steps" if key in DDIM_STEPS_METHODS else "Steps"


def steps_from_flags(steps: Any, ddim_steps: Any, methods: Iterable[str]) -> dict:
    """The CLI's and the page's two step settings as steps per method: `--ddim-steps` / the DDIM slider for the
    diffusion methods, `--steps` / the steps slider for every other method (the interface the README documents).
    Values are passed on as given: the receiver checks them (a page or API value may be anything)."""
    return {k: (ddim_steps if steps_setting(k) == "ddim_steps" else steps) for k in methods}


__all__ = ["COLORS", "DDIM_STEPS_METHODS", "GROUND_TRUTH_KEY", "LABELS", "label", "steps_from_flags", "steps_setting",
           "steps_setting_name"]
