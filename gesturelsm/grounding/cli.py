"""`--grounding on|off`: the one flag every command that makes motion carries (generate, batch, sweep)."""
from __future__ import annotations

import argparse


def add_grounding_flag(p: argparse.ArgumentParser) -> None:
    p.add_argument("--grounding", choices=["on", "off"], default="on",
                   help="feet on the ground: planted feet, no drift, the body on the floor (docs/GROUNDING.md); "
                        "'off' keeps the decoder's root and legs")


def grounding_on(args: argparse.Namespace) -> bool:
    return getattr(args, "grounding", "on") == "on"
