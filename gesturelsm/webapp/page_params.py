"""The page handlers' parameters and the Gradio API's named parameters, made from the settings object
(`gesturelsm.settings.page_params`: the speech, transcript, TextGrid and video size, then every setting at its place),
and the request they make (`gesturelsm.serve.request.Request`, each setting by its name).

    @page_handler("character", "words", optional_from="grounding", request=True, progress=True)
    def show_motion(self, sent, character=None, words=None, request=None, progress=None): ...

Gradio reads a handler's positional parameters for the API's names, its defaults for the optional ones, and passes
`gr.Request` and `gr.Progress` only to positional parameters it recognises by annotation and default; the handler made
here has exactly that signature and hands the body `sent`: {parameter: value as sent}. A setting added to the settings
object is a parameter of every handler (optional, with its default) and of the API, and a control of the page
(`webapp/controls.py`), with no other edit.
"""
from __future__ import annotations

import inspect
from typing import Any, Callable, Mapping

import gradio as gr

from gesturelsm.serve.request import Request
from gesturelsm.settings import page_params, settings_of

OWN = {"audio": "audio_path", "text": "text", "textgrid": "textgrid_path", "size": "size"}   # the request's own


def _signature(extra: tuple[str, ...], optional_from: str, request: bool, progress: bool) -> inspect.Signature:
    names, defaults = page_params(), {s.param: s.default for s in settings_of()}
    first = names.index(optional_from)
    kind = inspect.Parameter.POSITIONAL_OR_KEYWORD
    params = [inspect.Parameter("self", kind)]
    params += [inspect.Parameter(n, kind, default=defaults[n] if i >= first else inspect.Parameter.empty)
               for i, n in enumerate(names)]
    params += [inspect.Parameter(e, kind, default=None) for e in extra]
    if request:
        params.append(inspect.Parameter("request", kind, default=None, annotation=gr.Request))
    if progress:
        params.append(inspect.Parameter("progress", kind, default=gr.Progress()))
    return inspect.Signature(params)


def page_handler(*extra: str, optional_from: str, request: bool = False, progress: bool = False) -> Callable:
    """A method `fn(self, sent, *extra, [request], [progress])` as Gradio calls it: positionally, the page's
    parameters in `page_params()` order (those from `optional_from` on with their setting's default), then `extra`
    (default None), then the page session and the progress tracker where asked for. A generator stays one."""
    def wrap(fn: Callable) -> Callable:
        sig = _signature(extra, optional_from, request, progress)
        names = page_params()

        def call(*args: Any, **kwargs: Any) -> Any:
            bound = sig.bind(*args, **kwargs)
            bound.apply_defaults()
            given = dict(bound.arguments)
            self = given.pop("self")
            return fn(self, {n: given.pop(n) for n in names}, **given)

        def stream(*args: Any, **kwargs: Any) -> Any:
            yield from call(*args, **kwargs)

        made = stream if inspect.isgeneratorfunction(fn) else call
        made.__name__, made.__qualname__, made.__doc__ = fn.__name__, fn.__qualname__, fn.__doc__
        made.__signature__ = sig                                # type: ignore[attr-defined]
        made.__annotations__ = {"request": gr.Request} if request else {}
        return made
    return wrap


def make_request(sent: Mapping[str, Any], **more: Any) -> Request:
    """The request of the page's values `sent` (exactly as sent: the service checks them), each by its name."""
    by_param = {s.param: s.name for s in settings_of()}
    return Request(**{OWN.get(p) or by_param[p]: v for p, v in sent.items()}, **more)


__all__ = ["OWN", "make_request", "page_handler"]
