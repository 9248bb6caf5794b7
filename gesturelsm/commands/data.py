"""`gesturelsm data info ROOT`: check a BEAT2-layout folder and list what would be used."""
from __future__ import annotations

import argparse

NAME = "data"
HELP = "inspect a BEAT2-layout dataset folder"


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(NAME, help=HELP, description=__doc__)
    s = p.add_subparsers(dest="data_command", metavar="ACTION", required=True)
    info = s.add_parser("info", help="list takes, durations, transcripts and splits",
                        description="Check a BEAT2-layout folder and list its takes: frames, seconds of motion and "
                                    "of audio, transcript words, and each take's split.")
    info.add_argument("root", help="BEAT2-layout folder (smplxflame_30/, wave16k/, textgrid/)")
    info.add_argument("--speakers", nargs="*", help="speaker ids or names to keep (e.g. 2 scott)")
    info.set_defaults(func=run_info)


def run_info(args: argparse.Namespace) -> int:
    from ..constants import SAMPLE_RATE
    from ..data.beat2 import Beat2Dataset

    ds = Beat2Dataset(args.root, speakers=args.speakers)
    print(f"{ds.root}: {len(ds.names)} motion takes, {len(ds.audio_only_names)} audio-only takes")
    print(f"{'take':<28}{'frames':>8}{'seconds':>9}{'audio s':>9}{'words':>7}  split")
    for name in ds.names + ds.audio_only_names:
        take = ds.load(name)
        audio_s = f"{len(take.audio) / SAMPLE_RATE:.2f}" if take.audio is not None else "-"
        words = str(len([w for w in take.words if w.text])) if take.words is not None else "-"
        frames = take.motion.num_frames if take.motion is not None else "-"
        secs = f"{take.motion.duration:.2f}" if take.motion is not None else "-"
        print(f"{name:<28}{frames:>8}{secs:>9}{audio_s:>9}{words:>7}  {take.split or '-'}")
    return 0
