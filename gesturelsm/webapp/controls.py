"""The page's setting controls, made from the settings object's fields (`gesturelsm.settings.controls.Control`:
kind, element id, label, info, bounds, step) for the methods one server offers; the page only places them.

    make = controls_of(service)
    with gr.Row():
        steps, cfg = make("steps"), make("cfg")

Every control hands its value to the checks as sent (`raw_inputs.pass_through`): the settings' validator refuses a
bad one with its own message.
"""
from __future__ import annotations

from typing import Any, Callable

import gradio as gr

from gesturelsm.settings import Setting, settings_of
from gesturelsm.settings.controls import Offer, given

from .raw_inputs import pass_through

COMPONENTS = {"checkbox": gr.Checkbox, "radio": gr.Radio, "dropdown": gr.Dropdown, "slider": gr.Slider,
              "number": gr.Number, "checkboxes": gr.CheckboxGroup, "text": gr.Textbox}


def offer_of(service: Any) -> Offer:
    """What `service` offers the page: the methods a visitor may choose, the loaded ones, the step caps."""
    return Offer(tuple(service.methods), tuple(service.pipeline.methods), service.limits)


def page_control(s: Setting, offer: Offer | None = None, elem_id: str | None = None) -> Any:
    """The Gradio component of setting `s` as its field says (`Setting.page_control`), for `offer`'s methods;
    `elem_id`: another element id (the Sweep tab's copy of a control)."""
    c = s.page_control
    value = given(c.value, offer)
    kwargs: dict[str, Any] = {"value": s.default if value is None else value, "label": c.label or s.label}
    for name, part in (("elem_id", elem_id or c.elem_id), ("info", given(c.info, offer)), ("step", c.step),
                       ("precision", c.precision)):
        if part is not None:
            kwargs[name] = part
    args: tuple = ()
    if c.kind in ("radio", "dropdown", "checkboxes"):
        choices = given(c.choices, offer)
        args = (list(s.argparse.get("choices", ())) if choices is None else choices,)
    elif c.kind == "slider":
        assert c.bounds is not None, f"the slider of {s.name} says no bounds"
        args = tuple(c.bounds(offer))
    return pass_through(COMPONENTS[c.kind](*args, **kwargs))


def controls_of(service: Any) -> Callable[[str], Any]:
    """`make(param)`: the control of the setting whose page parameter is `param`, for `service`'s methods."""
    offer = offer_of(service)
    by_param = {s.param: s for s in settings_of()}
    return lambda param: page_control(by_param[param], offer)


__all__ = ["COMPONENTS", "controls_of", "offer_of", "page_control"]
