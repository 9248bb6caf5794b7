"""Input components that hand the function exactly what the browser or API client sent.

Gradio's own preprocessing of sliders, numbers and choice lists rounds (`precision=0` turns seed 1.5 into
2), compares with `<` (a string or None then fails with a generic error and a server traceback) and raises
its own wording for values outside the choices. The app checks every field itself, before any work, with
one line per field (`gesturelsm.serve.limits` / `gesturelsm.serve.checks`), so `pass_through` replaces the
component's `preprocess` on that one instance: the component stays a plain Gradio Slider / Number /
CheckboxGroup / Radio / Dropdown / Checkbox for the page (same block name and class id).
"""
from __future__ import annotations

from typing import Any, TypeVar

C = TypeVar("C")


def _unchanged(payload: Any) -> Any:
    return payload


def pass_through(component: C) -> C:
    """`component` with preprocessing switched off (Gradio looks `preprocess` up on the instance)."""
    component.preprocess = _unchanged          # type: ignore[attr-defined]
    return component
