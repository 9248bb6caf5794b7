"""The one validator of generation settings, used by every entry point: the page's Generate and Sweep, the Gradio
API, `gesturelsm generate / sweep / batch / eval / live`, the study batch and the pipeline itself.

    settings = checked(Asked(methods=["gesturelsm", "ddim"], steps=8, ddim_steps=20, cfg=2.0, seed=0),
                       available=pipe.methods)                   # InputError listing every problem, one per line

Values are checked as sent (`values.py`) against each chosen method's spec (`gesturelsm.backends.SPECS`: steps from
1 to its max_steps, CFG from 0 to its max_cfg) and the entry point's `Limits` (a server's step caps); fields are
named as the entry point shows them (`PAGE`: "Steps", `CLI`: "--steps"). What it checks is each field of the settings
object (`fields.py`): a field added there with its check is checked, named and defaulted here with no other edit.
"""
from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any, Mapping, Sequence

from ..errors import InputError
from .controls import cfg_bound
from .defaults import Limits, Settings
from .fields import MISSING, walk
from .schema import CLI, PAGE, Asked, Names, named, settings_class, settings_of
from .values import check_language, method_list, number_list, real_number, whole_number

if TYPE_CHECKING:           # the methods' registry (and torch with it) is loaded on first use, not with the settings
    from ..backends import MethodSpec


def _given(value: Any, default: Any) -> Any:
    return default if value is MISSING else value


def steps_per_method(asked: Asked, methods: Sequence[str]) -> dict[str, tuple[Any, str]]:
    """{method: (value as sent, name of the setting that gave it)} for the chosen methods that have a spec; methods
    whose setting was not sent are left out (they run their default)."""
    from ..backends import SPECS

    out = {}
    for m in methods:
        if m not in SPECS:
            continue                                # ground truth: no steps
        spec = SPECS[m]
        if isinstance(asked.steps, Mapping):
            if m in asked.steps:
                out[m] = (asked.steps[m], spec.steps_setting)
        elif spec.steps_setting == "ddim_steps" and asked.ddim_steps is not MISSING:
            out[m] = (asked.ddim_steps, "ddim_steps")
        elif asked.steps is not MISSING and (spec.steps_setting == "steps" or asked.ddim_steps is MISSING):
            out[m] = (asked.steps, "steps")
    return out


def check_steps(asked: Asked, methods: Sequence[str], limits: Limits, names: Names, problems: list[str]) -> dict | None:
    """Steps per method, each within its spec's bound and the entry point's cap for its setting. A value is checked
    once against the widest bound of the methods it drives (type, emptiness, below 1), then against each method's
    own, naming the method when the bounds differ."""
    from ..backends import SPECS, method_spec

    groups: dict[tuple[str, str], list[str]] = {}
    values: dict[tuple[str, str], Any] = {}
    for m, (value, setting) in steps_per_method(asked, methods).items():
        key = (setting, repr(value))
        groups.setdefault(key, []).append(m)
        values[key] = value
    steps: dict[str, Any] = {}
    found: list[str] = []
    for key, ms in groups.items():
        field, value = getattr(names, key[0]), values[key]
        highs = {m: limits.max_steps(method_spec(m)) for m in ms}
        widest = whole_number(value, field, 1, max(highs.values()), found)
        for m in ms if widest is not None else ():
            named = field if len(set(highs.values())) == 1 else f"{field} for {method_spec(m).label}"
            steps[m] = whole_number(widest, named, 1, highs[m], found)
    for setting in ("steps", "ddim_steps"):            # a value sent for no chosen method is still checked
        value = getattr(asked, setting)
        if not any(k[0] == setting for k in groups) and value is not MISSING and not isinstance(value, Mapping):
            hi = max(limits.max_steps(s) for s in SPECS.values() if s.steps_setting == setting)
            whole_number(value, getattr(names, setting), 1, hi, found)
    problems += list(dict.fromkeys(found))
    return None if found else steps


def seed_problems(value: Any, names: Names, problems: list[str]) -> int | None:
    """A seed: a whole number from 0 to SEED_MAX, never rounded (the settings' own check of it)."""
    check = named("seed").check
    assert check is not None                           # the seed's field always has its check
    return check(value, names.seed, problems)


def checked_seed(value: Any, names: Names = PAGE) -> int:
    """A seed sent alone (the page's Edit), checked as the settings' seed is: the int, or an InputError."""
    p: list[str] = []
    seed = seed_problems(value, names, p)
    if p or seed is None:
        raise InputError("\n".join(p))
    return seed


def _built(cls: type, values: Mapping[str, Any]) -> Any:
    """`cls` (the settings object, or one nested in it) made from the checked values by field name."""
    kwargs = {}
    for f in dataclasses.fields(cls):
        if "setting" in f.metadata:
            kwargs[f.name] = values[f.name]
        elif dataclasses.is_dataclass(f.default):
            kwargs[f.name] = _built(type(f.default), values)
    return cls(**kwargs)


def settings_problems(asked: Asked, available: Sequence[str], limits: Limits = Limits(), names: Names = PAGE,
                      default_methods: Sequence[str] | None = None,
                      cls: type | None = None) -> tuple[Settings | None, list[str]]:
    """(the settings, []) or (None, every problem, one line each). `available`: the methods that may be chosen (the
    loaded ones, ground truth where a BEAT2 folder is set); `default_methods` when none were sent; `cls`: the settings
    object, whose fields say what is checked (each its own check; methods, steps and CFG against the methods)."""
    cls = settings_class(cls)
    known = {s.name for s in settings_of(cls)}
    if asked.names() - known:
        raise TypeError(f"not settings: {sorted(asked.names() - known)}")
    p: list[str] = []
    values: dict[str, Any] = {}
    methods: list[str] = []
    for s in settings_of(cls):
        sent = getattr(asked, s.name)
        if s.name == "methods":
            default = list(default_methods if default_methods is not None else s.default)
            methods = method_list(default if sent is MISSING else sent, list(available), p, names.of(s)) or []
            values["methods"] = tuple(methods)
        elif s.name == "steps":
            values["steps"] = check_steps(asked, methods, limits, names, p)
        elif s.name == "cfg":
            values["cfg"] = real_number(_given(sent, s.default), names.of(s), 0.0, cfg_bound(methods), p)
        elif s.check is not None and not s.merged:
            values[s.name] = s.check(_given(sent, s.default), names.of(s), p)
    if p:
        return None, p
    return _built(cls, values), []


def checked(asked: Asked, available: Sequence[str], limits: Limits = Limits(), names: Names = PAGE,
            default_methods: Sequence[str] | None = None) -> Settings:
    """The settings, or an InputError with every problem, one per line."""
    settings, problems = settings_problems(asked, available, limits, names, default_methods)
    if problems or settings is None:
        raise InputError("\n".join(problems))
    return settings


def asked_of(settings: Any) -> Asked:
    """The values of a settings object made in code, by the settings' names, as an entry point would send them."""
    values = {}
    for path, s in walk(type(settings)):
        if not s.merged:
            value = settings
            for part in path:
                value = getattr(value, part)
            values[s.name] = value
    return Asked(**values)


def checked_object(settings: Settings, available: Sequence[str], limits: Limits = Limits(),
                   names: Names = PAGE) -> Settings:
    """A settings object made in code (`settings=Settings(...)` of the Python API) checked by the one validator, as
    the page's and the command line's values are: the settings normalised, or an InputError with every problem."""
    valid, problems = settings_problems(asked_of(settings), available, limits, names, cls=type(settings))
    if problems or valid is None:
        raise InputError("\n".join(problems))
    return valid


def check_method_settings(spec: MethodSpec, steps: Any, cfg: Any, limits: Limits = Limits()) -> None:
    """One method's steps and CFG scale against its spec (the pipeline's own check, for callers of its Python API):
    InputError naming the method."""
    p: list[str] = []
    whole_number(steps, f"Steps for {spec.label}", 1, limits.max_steps(spec), p)
    real_number(cfg, f"CFG scale for {spec.label}", 0.0, spec.max_cfg, p)
    if p:
        raise InputError("\n".join(p))


def grid_problems(methods: Sequence[str], steps: Any, cfgs: Any, seeds: Any, max_seeds: int, limits: Limits,
                  names: Names, problems: list[str]) -> tuple[tuple[int, ...], tuple[float, ...], int] | None:
    """A sweep's lists: step counts and CFG scales (each within every chosen method's bounds) and a seed count."""
    n = len(problems)
    step_list = number_list(steps, names.steps, True, problems)
    found: list[str] = []
    for s in step_list or ():
        check_steps(Asked(steps=s), methods, limits, names, found)
    problems += list(dict.fromkeys(found))
    cfg_list, found = number_list(cfgs, names.cfg, False, problems), []
    for c in cfg_list or ():
        real_number(c, names.cfg, 0.0, cfg_bound(methods), found)
    problems += list(dict.fromkeys(found))
    count = whole_number(seeds, "Seeds" if names is PAGE else "--seeds", 1, max_seeds, problems)
    if len(problems) > n or step_list is None or cfg_list is None or count is None:
        return None
    return step_list, cfg_list, count


__all__ = ["Asked", "CLI", "MISSING", "Names", "PAGE", "asked_of", "cfg_bound", "check_language",
           "check_method_settings", "check_steps", "checked", "checked_object", "checked_seed", "grid_problems",
           "seed_problems", "settings_problems", "steps_per_method"]
