"""The kinds of speech variant `gesturelsm train --augment` can add (augment.py makes them), without torch, so the
command's `--help` lists them before any model code loads."""
KINDS = ("tempo", "pitch", "gain")
