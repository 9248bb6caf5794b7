"""The web demo's Gradio page over `gesturelsm.serve` (no request logic of its own): `ui.py` builds the page and
launches it, `live.py` the Live tab, `live_socket.py` its microphone WebSocket route, `player/` the in-browser player
(its JavaScript, its bundle and its Gradio side), `aside.py` side work at a lower priority, `raw_inputs.py` inputs
handed over as sent; `gesturelsm.commands.serve` is the `gesturelsm serve` / `python -m app` command. Importing this
package loads nothing (Gradio is imported by the modules that use it)."""
