"""Names a package exports but imports on first use (a module `__getattr__`, PEP 562), so that importing the package
loads none of its heavy modules (torch) until one of those names is read.

    _HOME = {"StreamingGenerator": "stream"}          # name -> the submodule that defines it
    __getattr__ = lazy_names(__name__, _HOME)
"""
from __future__ import annotations

import importlib
import sys
from typing import Any, Callable, Mapping


def lazy_names(package: str, home: Mapping[str, str]) -> Callable[[str], Any]:
    """`package`'s module `__getattr__`: a name of `home` is imported from its submodule at its first read and kept in
    the package (later reads do not come here); any other name is an AttributeError, as for a plain module."""
    def __getattr__(name: str) -> Any:
        if name not in home:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f".{home[name]}", package), name)
        setattr(sys.modules[package], name, value)
        return value
    return __getattr__


__all__ = ["lazy_names"]
