"""How the page shows each setting, said on the setting's field (`fields.Setting.control`): the kind of control, its
element id, its label where the page words it otherwise than the messages, its info line, its bounds and step, and
what of it follows the methods a server loads (`Offer`). `gesturelsm.webapp.controls` makes the Gradio component of
it; a setting without a `Control` gets `default_control` (a checkbox for a switch, choices for a setting with
choices, a number box for a number, else a text box).

    cfg: float = setting(DEFAULT_CFG, ..., control=Control("slider", step=0.1, bounds=cfg_range))

Torch-free: the methods' specs (`gesturelsm.backends`) are read when a control is made, not at import.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Sequence, Union

KINDS = ("checkbox", "radio", "dropdown", "slider", "number", "checkboxes", "text")


@dataclass(frozen=True)
class Offer:
    """What one server offers the page: the methods a visitor may choose (ground truth where a BEAT2 folder is set),
    the generators it loaded, and its limits (`defaults.Limits`: the step caps)."""
    methods: tuple[str, ...]
    loaded: tuple[str, ...]
    limits: Any


Of = Callable[[Any], Any]                       # a part of a control that follows the server's methods (an Offer)
Given = Union[Any, Of]                          # a value, or a function of the offer


@dataclass(frozen=True)
class Control:
    """One setting's control on the page. `kind`: one of KINDS ("checkboxes": several choices at once); `elem_id`:
    its element id (a contract of the page; None: none); `label`: None for the setting's label; `info`, `value`
    (None: the setting's default), `choices` (None: the flag's choices) and `bounds` ((lowest, highest) of a slider)
    may each be a function of the server's `Offer`; `step`: a slider's; `precision`: a number box's."""
    kind: str
    elem_id: str | None = None
    label: str | None = None
    info: Given = None
    value: Given = None
    choices: Given = None
    bounds: Of | None = None
    step: float | None = None
    precision: int | None = None

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"a control's kind is one of {', '.join(KINDS)} (got {self.kind!r})")


def given(part: Given, offer: Offer | None) -> Any:
    """A part of a control as shown for `offer`."""
    return part(offer) if callable(part) else part


def default_control(name: str, default: Any, choices: Sequence | None) -> Control:
    """The control of a setting that says none: its element id its name with hyphens."""
    elem_id = name.replace("_", "-")
    if isinstance(default, bool):
        return Control("checkbox", elem_id)
    if choices:
        return Control("radio", elem_id, choices=list(choices))
    if isinstance(default, (int, float)):
        return Control("number", elem_id)
    return Control("text", elem_id)


# ---- the parts that follow the server's methods (the methods' specs, `gesturelsm.backends.SPECS`) ----------------

def cfg_bound(methods: Sequence[str]) -> float:
    """The largest CFG scale every chosen method accepts."""
    from ..backends import SPECS

    return min((SPECS[m].max_cfg for m in methods if m in SPECS), default=max(s.max_cfg for s in SPECS.values()))


def cfg_range(offer: Offer) -> tuple[float, float]:
    """The CFG slider: from 0 to the largest scale every loaded method accepts."""
    return 0.0, cfg_bound(offer.loaded)


def _step_specs(offer: Offer, setting: str) -> list:
    from ..backends import SPECS

    return [SPECS[m] for m in offer.loaded if m in SPECS and SPECS[m].steps_setting == setting] or \
        [s for s in SPECS.values() if s.steps_setting == setting]


def step_range(setting: str) -> Of:
    """A step slider: from 1 to the most steps this server accepts for the methods the setting drives (each method's
    spec, the server's caps)."""
    return lambda offer: (1, max(offer.limits.max_steps(s) for s in _step_specs(offer, setting)))


def step_value(setting: str) -> Of:
    """A step slider starts at the first method's default steps."""
    return lambda offer: _step_specs(offer, setting)[0].default_steps


def step_info(setting: str) -> Of:
    """"for GestureLSM, Rectified flow": the methods a step slider drives."""
    return lambda offer: "for " + ", ".join(s.label for s in _step_specs(offer, setting))


def method_choices(offer: Offer) -> list[tuple[str, str]]:
    from ..backends import label

    return [(label(m), m) for m in offer.methods]


def methods_shown(offer: Offer) -> list[str]:
    """The methods ticked at first: up to three of those trained here."""
    from ..backends import ours_default

    return [m for m in ours_default() if m in offer.methods][:3]


def methods_info(offer: Offer) -> str | None:
    """What the choices' specs say a visitor should know: the authors' released weights run in our windowing, and
    the methods that generate no face."""
    from ..backends import SPECS

    specs = [SPECS[m] for m in offer.methods if m in SPECS]
    notes = ["Authors' weights: their released models; long speech uses our windowing with a neutral first seed."] \
        if any(s.imported for s in specs) else []
    faceless = [s.label for s in specs if "face" not in s.regions]
    if faceless:
        notes.append(f"{', '.join(faceless)} generate no face, so the face stays neutral.")
    return " ".join(notes) or None


__all__ = ["Control", "KINDS", "Offer", "cfg_bound", "cfg_range", "default_control", "given", "method_choices",
           "methods_info", "methods_shown", "step_info", "step_range", "step_value"]
