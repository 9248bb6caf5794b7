"""Serving the demo on the web, without any UI: the request flow (`service.py`: upload -> speech -> motions ->
video -> downloads) and its values (`request.py`), a request's checks before any work (`checks.py`, with the rules
and numbers in `limits.py`) and how long outputs live (`lifetime.py`). What an uploaded file really is, is
`gesturelsm.audio`'s to say, below this package; the Gradio page over it is `gesturelsm.webapp`.

Importing this package loads nothing: its modules are imported by name."""
