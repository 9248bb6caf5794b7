"""The page's Speech language choices (`#language` for Generate, `#sweep-language` for Sweep): auto (English first)
or one of the recogniser's languages."""
from __future__ import annotations

import gradio as gr

from gesturelsm.asr.languages import LANGUAGES
from gesturelsm.settings import DEFAULTS

from .raw_inputs import pass_through


def language_choice(elem_id: str = "language") -> gr.Dropdown:
    """A dropdown whose value goes to the request as sent (the settings' validator checks it): the Generate tab's
    `#language` and the Sweep tab's `#sweep-language`, the same choices and default."""
    return pass_through(gr.Dropdown([("Automatic (English first)", "auto"), *((f"{n} ({c})", c) for c, n in
                                                                             LANGUAGES.items())],
                                    value=DEFAULTS.language, label="Speech language", elem_id=elem_id))
