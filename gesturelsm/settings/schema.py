"""The settings object's fields as each entry point sees them (`fields.py` says what each one is): every setting in
order (`settings_of`), the names the validator's messages give them (`Names`: `PAGE`, `CLI`), what an entry point was
sent (`Asked`, by the settings' names) and the page handlers' and the Gradio API's parameters (`page_params`).
"""
from __future__ import annotations

from typing import Any

from .defaults import Settings
from .fields import MISSING, Setting, walk


def settings_class(cls: type | None = None) -> type:
    """`cls`, or the shipped settings object (`Settings`) where None."""
    return Settings if cls is None else cls


def settings_of(cls: type | None = None) -> tuple[Setting, ...]:
    """Every setting of the settings object `cls` (default: the shipped `Settings`), in its fields' order."""
    return tuple(s for _, s in walk(settings_class(cls)))


def named(name: str, cls: type | None = None) -> Setting:
    for s in settings_of(cls):
        if s.name == name:
            return s
    raise KeyError(name)


def page_params(cls: type | None = None) -> tuple[str, ...]:
    """The page handlers' and the Gradio API's parameters, in order: the request's own (speech, transcript, TextGrid,
    video size) and every setting's, each at its `page` place."""
    own = [(0, "audio"), (1, "text"), (2, "textgrid"), (10, "size")]
    return tuple(p for _, p in sorted(own + [(s.page, s.param) for s in settings_of(cls)], key=lambda x: x[0]))


class Names:
    """How an entry point names each setting in its messages: `PAGE.cfg` is "CFG scale", `CLI.cfg` "--cfg"."""

    def __init__(self, attribute: str):
        self._attribute = attribute

    def of(self, s: Setting) -> str:
        return getattr(s, self._attribute)

    def __getattr__(self, name: str) -> str:
        if name.startswith("_"):
            raise AttributeError(name)
        try:
            return self.of(named(name))
        except KeyError:
            raise AttributeError(name) from None

    def __repr__(self) -> str:
        return f"Names({self._attribute!r})"


PAGE = Names("label")
CLI = Names("flag")


class Asked:
    """Settings exactly as an entry point received them, by the settings' names (positionally in their order:
    methods, steps, ddim_steps, ...). `steps`: one value for every chosen method, or for those its "steps" setting
    drives when `ddim_steps` is given too (the page's two sliders, `--steps` / `--ddim-steps`), or {method: value}.
    A setting not given is MISSING and takes its default (a method's own steps, `DEFAULTS` for the rest); None is a
    value that was sent empty, and is refused."""

    def __init__(self, *args: Any, **values: Any):
        names = [s.name for s in settings_of()]
        given = dict(zip(names, args))
        if len(args) > len(names) or set(given) & set(values):
            raise TypeError("Asked: too many values, or one given twice")
        self._values = {**given, **values}

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):
            raise AttributeError(name)
        return self._values.get(name, MISSING)

    def names(self) -> set[str]:
        return {k for k, v in self._values.items() if v is not MISSING}

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Asked) and {k: v for k, v in self._values.items() if v is not MISSING} == \
            {k: v for k, v in other._values.items() if v is not MISSING}

    def __repr__(self) -> str:
        return "Asked(" + ", ".join(f"{k}={v!r}" for k, v in self._values.items() if v is not MISSING) + ")"


__all__ = ["Asked", "CLI", "Names", "PAGE", "named", "page_params", "settings_class", "settings_of"]
