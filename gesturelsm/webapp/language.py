"""The page's Speech language choices (`#language` for Generate, `#sweep-language` for Sweep): auto (English first)
or one of the recogniser's languages."""
from __future__ import annotations

from typing import Any

from gesturelsm.settings.schema import named

from .controls import page_control


def language_choice(elem_id: str = "language") -> Any:
    """A dropdown whose value goes to the request as sent (the settings' validator checks it): the Generate tab's
    `#language` and the Sweep tab's `#sweep-language`, the same choices and default (the language setting's control,
    `webapp/controls.py`)."""
    return page_control(named("language"), elem_id=elem_id)
