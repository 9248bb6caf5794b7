"""Serving the demo on the web, without any UI: the service (`service.py`: upload -> speech -> motions -> video ->
downloads) composed of the request's checks and speech (`intake.py`, with the rules and numbers in `checks.py` and
`limits.py`), its folders and file names (`gesturelsm/request_files.py`), the motion made ahead of the click
(`ahead.py`), the render queue (`renders.py`) and one generation port (`port.py`) with two implementations: this
process (`local.py`, the request flow in `progressive.py`, edits in `editing.py`, sweeps in `sweep.py`) and Ray
Serve replicas (`replicated.py`, `replicas.py`); the request's values (`request.py`) and how long outputs live
(`lifetime.py`). What an uploaded file really is, is `gesturelsm.audio`'s to say, below this package; the Gradio
page over it is `gesturelsm.webapp`.

Importing this package loads nothing: its modules are imported by name."""
