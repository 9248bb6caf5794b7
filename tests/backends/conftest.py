"""The authors' reduced-size checkpoints, as tests/reference/conftest.py builds them, for the registry's tests."""
from __future__ import annotations

import importlib.util
from pathlib import Path

_spec = importlib.util.spec_from_file_location("reference_conftest",
                                               Path(__file__).resolve().parents[1] / "reference" / "conftest.py")
_reference = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_reference)
ckpt_dir = _reference.ckpt_dir          # the same session fixture
