"""The page with what runs beside it: `Demo` holds the Gradio Blocks that `ui.build_demo` builds, the Live tab's
streams and its socket's routes. `launch` serves them (with the upload limit and the output folder allowed) and
sweeps expired outputs on a timer (gesturelsm.serve.lifetime); `close` stops the server, the live streams and the
sweeper, which deletes every output."""
from __future__ import annotations

from dataclasses import dataclass, field

import gradio as gr
from starlette.routing import BaseRoute

from gesturelsm.live.session import LiveManager
from gesturelsm.serve.lifetime import Sweeper, sweep_seconds
from gesturelsm.serve.service import GestureService

from .layout import PAGE_CSS
from .player.component import served_paths


@dataclass(eq=False)
class Demo:
    blocks: gr.Blocks                       # the page
    service: GestureService                 # the requests it serves
    live: LiveManager | None = None         # the Live tab's streams (None: no Live tab)
    routes: list[BaseRoute] = field(default_factory=list)      # the live socket, served beside the page
    sweeper: Sweeper | None = field(default=None, repr=False)  # started by launch
    css: str = PAGE_CSS                     # the page's stylesheet (layout.py)

    def launch(self, host: str = "127.0.0.1", port: int = 7860, **kw):
        """Serve the page and its routes; returns what `Blocks.launch` returns. A blocking launch stops everything
        when it ends (as `close()` or interpreter exit do)."""
        service = self.service
        keep = service.settings.keep_minutes
        self.sweeper = Sweeper(service.cleanup, sweep_seconds(keep), final=lambda: service.cleanup(max_age_s=0)).start()
        app_kwargs = dict(kw.pop("app_kwargs", None) or {})
        app_kwargs["routes"] = [*app_kwargs.get("routes", []), *self.routes]
        try:
            return self.blocks.launch(server_name=host, server_port=port,
                                      max_file_size=f"{int(service.settings.max_upload_mb)}mb",
                                      allowed_paths=[str(service.workdir), *served_paths()],
                                      footer_links=["api"], app_kwargs=app_kwargs, css=kw.pop("css", self.css),
                                      **kw)
        finally:
            if not kw.get("prevent_thread_lock"):
                self._stop()

    def close(self) -> None:
        """Stop the server, every live stream (no live worker outlives it) and the sweeper (deleting all outputs)."""
        try:
            self.blocks.close()
        finally:
            self._stop()

    def _stop(self) -> None:
        if self.live is not None:
            self.live.stop_all()
        if self.sweeper is not None:
            self.sweeper.stop()
