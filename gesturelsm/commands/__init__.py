"""The `gesturelsm` subcommands, one module per command, named after it (`gesturelsm import-reference`:
import_reference.py); `gesturelsm.cli` lists them in the order `gesturelsm --help` shows them.

Each module has `NAME` (the command), `HELP` (its line in `gesturelsm --help`) and `add_parser(subparsers)`, which
makes its parser and sets `func` (the function that runs it). A module imports at its top only what its parser needs
without torch (errors, constants, the settings' flags and checks, the cluster's flag); what a parser shows of the
methods, the body regions, the sweep and the live mode (the backend registry, flows/facts.py, motion/regions.py,
evaluation/sweep_limits.py, live/config.py: each loads without torch) is imported by `add_parser`, everything that
does the work by the run function. So `gesturelsm --help`, which builds no command's parser, and the `--help` of
every command load no torch.
"""
