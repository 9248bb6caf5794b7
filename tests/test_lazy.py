"""gesturelsm.lazy: a package's names imported from their submodule at the first read, kept in the package, and any
other name an AttributeError (as for a plain module)."""
from __future__ import annotations

import sys

import pytest


def test_a_name_is_imported_at_its_first_read_and_kept(tmp_path, monkeypatch):
    pkg = tmp_path / "lazypkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("from gesturelsm.lazy import lazy_names\n"
                                     "__getattr__ = lazy_names(__name__, {'VALUE': 'heavy'})\n")
    (pkg / "heavy.py").write_text("VALUE = 42\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    import lazypkg

    try:
        assert "lazypkg.heavy" not in sys.modules                      # importing the package loads nothing else
        assert lazypkg.VALUE == 42 and "lazypkg.heavy" in sys.modules
        assert "VALUE" in vars(lazypkg)                                  # kept: later reads do not come back
        with pytest.raises(AttributeError, match="has no attribute 'OTHER'"):
            lazypkg.OTHER
    finally:
        for name in ("lazypkg", "lazypkg.heavy"):
            sys.modules.pop(name, None)


@pytest.mark.parametrize("package", ["gesturelsm.backends", "gesturelsm.evaluation", "gesturelsm.live",
                                     "gesturelsm.motion"])
def test_no_lazy_name_is_also_a_submodule(package):
    """Importing a submodule sets it as the package's attribute of that name, after which the lazy name would be
    the module, not what the package exports (`from gesturelsm.evaluation import evaluate` once gave a module)."""
    import importlib
    import pkgutil

    pkg = importlib.import_module(package)
    assert not set(pkg._HOME) & {m.name for m in pkgutil.iter_modules(pkg.__path__)}
