"""Input components that hand the function exactly what the browser or API client sent.

Gradio's own preprocessing of sliders, numbers and choice lists rounds (`precision=0` turns seed 1.5 into
2), compares with `<` (a string or None then fails with a generic error and a server traceback) and raises
its own wording for values outside the choices. The app checks every field itself, before any work, with
one line per field (`gesturelsm.limits` / `gesturelsm.app_checks`), so these components pass the payload
through untouched. The page draws them as the usual Slider / Number / CheckboxGroup / Radio / Dropdown /
Checkbox (their block name is the Gradio parent's).
"""
from __future__ import annotations

from typing import Any

import gradio as gr


class _PassThrough:
    def _gradio_parent(self) -> type:
        return next(c for c in type(self).__mro__ if c.__module__.startswith("gradio."))

    def get_block_name(self) -> str:         # the Svelte component the page uses
        return self._gradio_parent().__name__.lower()

    def get_block_class(self) -> str:
        return self._gradio_parent().__name__.lower()

    def preprocess(self, payload: Any) -> Any:
        return payload

from gradio.events import Dependency

class Slider(_PassThrough, gr.Slider):
    pass
    from typing import Callable, Literal, Sequence, Any, TYPE_CHECKING
    from gradio.blocks import Block
    if TYPE_CHECKING:
        from gradio.components import Timer
        from gradio.components.base import Component


class Number(_PassThrough, gr.Number):
    pass
    from typing import Callable, Literal, Sequence, Any, TYPE_CHECKING
    from gradio.blocks import Block
    if TYPE_CHECKING:
        from gradio.components import Timer
        from gradio.components.base import Component


class CheckboxGroup(_PassThrough, gr.CheckboxGroup):
    pass
    from typing import Callable, Literal, Sequence, Any, TYPE_CHECKING
    from gradio.blocks import Block
    if TYPE_CHECKING:
        from gradio.components import Timer
        from gradio.components.base import Component


class Radio(_PassThrough, gr.Radio):
    pass
    from typing import Callable, Literal, Sequence, Any, TYPE_CHECKING
    from gradio.blocks import Block
    if TYPE_CHECKING:
        from gradio.components import Timer
        from gradio.components.base import Component


class Dropdown(_PassThrough, gr.Dropdown):
    pass
    from typing import Callable, Literal, Sequence, Any, TYPE_CHECKING
    from gradio.blocks import Block
    if TYPE_CHECKING:
        from gradio.components import Timer
        from gradio.components.base import Component


class Checkbox(_PassThrough, gr.Checkbox):
    pass
    from typing import Callable, Literal, Sequence, Any, TYPE_CHECKING
    from gradio.blocks import Block
    if TYPE_CHECKING:
        from gradio.components import Timer
        from gradio.components.base import Component