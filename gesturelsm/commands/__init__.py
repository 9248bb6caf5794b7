"""The `gesturelsm` subcommands, one module per command, named after it (`gesturelsm import-reference`:
import_reference.py); `gesturelsm.cli` lists them in the order `gesturelsm --help` shows them.

Each module has `NAME` (the command), `HELP` (its line in `gesturelsm --help`) and `add_parser(subparsers)`, which
makes its parser and sets `func` (the function that runs it). A module imports at its top only what its parser needs
without torch (errors, constants, the settings' flags and checks, the cluster's flag); the method registry a parser
shows (methods, their default steps) is imported by `add_parser`, everything that does the work by the run
function. So `gesturelsm --help`, which builds no command's parser, and the `--help` of a command that shows no
method, load no torch.
"""
