"""`python -m app`: start the web demo from a checkout (the page is `gesturelsm.webapp`; installed, the same demo is
`gesturelsm serve`). `python -m app --help` lists the flags and their environment variables."""
import sys

from gesturelsm.commands.serve import main

if __name__ == "__main__":
    sys.exit(main(prog="python -m app"))
