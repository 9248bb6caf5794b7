"""One settings object with its defaults (`defaults.py`), each field saying what it is to every entry point
(`fields.py`: label, flag, page parameter, check, whether it changes the motion), the one validator every entry point
checks what it was sent with (`check.py`, on `values.py`'s single-value checks), and the command line's flags and
argument checks built on them (`arguments.py`); a request's `Plan` (`plan.py`): its settings and where its ground
truth is looked up.
"""
from .check import (CLI, MISSING, PAGE, Asked, Names, check_method_settings, checked, checked_object, grid_problems,
                    settings_problems)
from .defaults import (DEFAULT_CFG, DEFAULT_METHOD, DEFAULTS, MAX_SECONDS, MIN_SECONDS, SEED_MAX, Limits, PostProcess,
                       Settings)
from .fields import Setting, motion_values, setting
from .schema import page_params, settings_of
from .plan import Plan

__all__ = ["Asked", "CLI", "DEFAULTS", "DEFAULT_CFG", "DEFAULT_METHOD", "Limits", "MAX_SECONDS", "MIN_SECONDS",
           "MISSING", "Names", "PAGE", "Plan", "PostProcess", "SEED_MAX", "Setting", "Settings",
           "check_method_settings", "checked", "checked_object", "grid_problems", "motion_values", "page_params",
           "setting", "settings_of", "settings_problems"]
