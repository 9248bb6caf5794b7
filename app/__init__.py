"""The GestureLSM web app: `python -m app` (or `make demo`). UI only; the work is in
`gesturelsm.serve.service`."""
