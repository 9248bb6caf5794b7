"""Serving the demo on the web, without any UI: the request flow (`service.py`: upload -> speech -> motions ->
video -> downloads) and its values (`request.py`), a request's checks before any work (`checks.py`, with the rules
and numbers in `limits.py`), upload format sniffing (`uploads.py`, also used by `gesturelsm.audio` for every audio
file) and how long outputs live (`lifetime.py`). The Gradio page over it is `gesturelsm.webapp`.

Importing this package loads nothing: `limits` and `uploads` sit on the package's lowest floor
(tests/test_architecture.py), the rest above the pipeline."""
