"""What each generation setting is, said once, on the field of the settings object that holds it
(`defaults.Settings`, `defaults.PostProcess`): its name on the page and in messages, its command-line flag, its page
handler's and the Gradio API's parameter name, its default, its check, whether it changes the motion and its
control on the page (`controls.Control`: kind, element id, info, bounds).

    cfg: float = setting(DEFAULT_CFG, label="CFG scale", flag="--cfg", param="cfg", page=5, cli="settings",
                         help="classifier-free guidance scale (default: {default:g})")

From these the rest is made (`schema.py`): the validator's field names (`Names`: `PAGE`, `CLI`) and what it
accepts (`Asked`), the command line's flags (`arguments.add_flag`), the page's and the API's parameters
(`page_params`), the page's controls (`webapp/controls.py`), the request's fields (`serve/request.py`) and the key
of motion made ahead (`motion_values`, here). A field added to the settings object with its `setting(...)` appears in
each of them.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Callable, Iterator, Mapping

from .controls import Control, default_control


class _Missing:
    def __repr__(self) -> str:
        return "MISSING"

    def __reduce__(self) -> str:
        """Pickled by name: a request sent to another process (a Ray Serve replica) keeps its fields MISSING."""
        return "MISSING"


MISSING: Any = _Missing()           # a field the entry point did not receive: its default is used


def _same(value: Any) -> Any:
    return value


@dataclass(frozen=True)
class Setting:
    """One setting as every entry point shows it. `check(value, field, problems)` returns the normalised value or
    None after adding one sentence to `problems` (`values.py`); None: the validator checks it with the methods
    chosen (methods, steps, CFG). `cli`: which shared flag builder adds its flag ("settings": with --cfg and --seed,
    "post": with --smoothing, "language", "methods", "transcribe"), None where none does (the steps: their flags
    depend on the methods, `arguments.add_settings_flags`).
    `page`: its place among the page handlers' and the API's parameters (a contract: new settings come last)."""
    name: str                                   # the field's name (Asked, Request, Settings or PostProcess)
    label: str                                  # the page's name, in the page's messages: "CFG scale"
    flag: str                                   # the command line's: "--cfg"
    param: str                                  # the page handlers' and the Gradio API's parameter: "in_place"
    default: Any = MISSING                      # MISSING: each method's own (steps)
    check: Callable[[Any, str, list[str]], Any] | None = None
    motion: bool = True                         # it changes the motion: part of the made-ahead key
    page: float = 100.0
    cli: str | None = "settings"
    help: str = ""                              # --help; "{default}" is the default
    argparse: Mapping[str, Any] = dataclasses.field(default_factory=dict)   # choices, action, metavar
    from_cli: Callable[[Any], Any] = _same      # the flag's value -> the value as sent ("on" -> True)
    merged: bool = False                        # checked into another field (ddim_steps into steps)
    control: Control | None = None              # the page's control (`controls.py`); None: `default_control`

    @property
    def page_control(self) -> Control:
        """The page's control of this setting: its own, else the one its default and choices suggest."""
        return self.control or default_control(self.name, self.default, self.argparse.get("choices"))

    @property
    def dest(self) -> str:
        """The flag's attribute on argparse's namespace: "--ddim-steps" -> "ddim_steps"."""
        return self.flag.lstrip("-").replace("-", "_")


def setting(default: Any = MISSING, *, also: tuple[Setting, ...] = (), factory: Callable[[], Any] | None = None,
            **meta: Any) -> Any:
    """A settings field with its `Setting` (named after the field when the class is made); `also`: further settings
    checked into the same field (the page's second step slider)."""
    kwargs: dict[str, Any] = {"metadata": {"setting": meta, "also": also}}
    if factory is not None:
        kwargs["default_factory"] = factory
    else:
        kwargs["default"] = default
    return dataclasses.field(**kwargs)


def _of(f: dataclasses.Field) -> Setting:
    default = f.default if f.default is not dataclasses.MISSING else MISSING
    return Setting(name=f.name, default=default, **f.metadata["setting"])


def walk(cls: type) -> Iterator[tuple[tuple[str, ...], Setting]]:
    """(path in the settings object, setting) of every setting of `cls`, in field order, nested objects (the
    post-processing) in place; a merged setting has its field's path."""
    for f in dataclasses.fields(cls):
        if "setting" in f.metadata:
            yield (f.name,), _of(f)
            for extra in f.metadata["also"]:
                yield (f.name,), extra
        elif dataclasses.is_dataclass(f.default):
            for path, s in walk(type(f.default)):
                yield (f.name, *path), s


def _frozen(value: Any) -> Any:
    if isinstance(value, Mapping):
        return tuple(sorted(value.items()))
    return tuple(value) if isinstance(value, (list, tuple)) else value


def motion_values(settings: Any) -> tuple:
    """The values of `settings` that change the motion (each setting marked `motion`), hashable, in field order."""
    out = []
    for path, s in walk(type(settings)):
        if s.motion and not s.merged:
            value = settings
            for part in path:
                value = getattr(value, part)
            out.append((s.name, _frozen(value)))
    return tuple(out)


__all__ = ["MISSING", "Setting", "motion_values", "setting", "walk"]
