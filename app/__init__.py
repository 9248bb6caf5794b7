"""The checkout's launcher for the web demo: `python -m app` (or `make demo`) serves `gesturelsm.webapp`, the Gradio
page (the in-browser player, its JavaScript and its bundle live in gesturelsm/webapp/player/), and developer tools
beside it (`python -m app.measure`, `python -m app.screenshot`). Not part of the installed wheel."""
