"""Input components that hand the function exactly what the browser or API client sent.

Gradio's own preprocessing of sliders, numbers and choice lists rounds (`precision=0` turns seed 1.5 into
2), compares with `<` (a string or None then fails with a generic error and a server traceback) and raises
its own wording for values outside the choices. The app checks every field itself, before any work, with
one line per field (`gesturelsm.serve.limits` / `gesturelsm.serve.checks`), so `pass_through` replaces the
component's `preprocess` on that one instance: the component stays a plain Gradio Slider / Number /
CheckboxGroup / Radio / Dropdown / Checkbox for the page (same block name and class id).
"""
from __future__ import annotations

from typing import Any, Sequence, TypeVar

C = TypeVar("C")


def _unchanged(payload: Any) -> Any:
    return payload


def pass_through(component: C) -> C:
    """`component` with preprocessing switched off (Gradio looks `preprocess` up on the instance)."""
    component.preprocess = _unchanged          # type: ignore[attr-defined]
    return component


def numeric_choices(component: C, values: Sequence[int]) -> C:
    """`component` (a Dropdown over whole numbers) passing values through, except that the text of a choice
    ('256' for 256) becomes the number: the API schema of a Dropdown lists its choices as strings
    (`Literal['256', ...]`), so a client that sends exactly what `view_api()` shows gets the same result as the
    page. Anything else reaches the field checks unchanged and is refused there with their message."""
    by_text = {str(v): v for v in values}

    def preprocess(payload: Any) -> Any:
        return by_text.get(payload, payload) if isinstance(payload, str) else payload

    component.preprocess = preprocess          # type: ignore[attr-defined]
    return component
