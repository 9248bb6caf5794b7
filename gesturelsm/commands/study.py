"""`gesturelsm study serve | invite | results`: run a web study over a `gesturelsm batch` folder and analyse it.

    gesturelsm batch --audio-dir speech/ --out study/ --raters 12      # videos, key, design, 12 links
    gesturelsm study serve study/ --port 8600                          # raters open http://HOST:8600/r/<token>
    gesturelsm study invite study/ 5                                   # 5 more links (the server picks them up)
    gesturelsm study results study/                                    # results/ : CSV, markdown, PNG

`study results` exits 0 with results written, 1 when nobody has answered yet, 2 on a bad argument or folder.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import UserError

NAME = "study"
HELP = "serve a web user study, invite raters, analyse the answers"


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(NAME, help=HELP,
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="study_command", metavar="ACTION", required=True)
    s = sub.add_parser("serve", help="host the study: one page per rater at /r/<token>",
                       description="Host the study of a `gesturelsm batch` folder: each rater's page at "
                                   "/r/<token>, answers stored as they are given.")
    s.add_argument("study_dir", help="folder made by `gesturelsm batch`")
    s.add_argument("--host", default="127.0.0.1", help="address to bind (default 127.0.0.1; 0.0.0.0 opens it)")
    s.add_argument("--port", type=int, default=8600, help="port to listen on")
    s.add_argument("--db", help="SQLAlchemy database URL (default: sqlite in STUDY_DIR/responses.sqlite)")
    s.set_defaults(func=run_serve)
    i = sub.add_parser("invite", help="add N raters and print their links",
                       description="Add N raters to a study made by `gesturelsm batch`: each gets an unguessable "
                       "link and a fixed list of trials; key/links.csv lists every rater's link (a running server "
                       "picks new raters up). Example: gesturelsm study invite study/ 5 --base-url "
                       "https://study.example.org")
    i.add_argument("study_dir", help="folder made by `gesturelsm batch`")
    i.add_argument("n", type=int, help="how many raters to add")
    i.add_argument("--base-url", help="the study's public address (where `study serve` is reached, e.g. "
                   "https://study.example.org): links are printed in full and key/links.csv gains a url column "
                   "(remembered for later invites; default: the address given before, else link paths only)")
    i.set_defaults(func=run_invite)
    r = sub.add_parser("results", help="unblind, apply the attention rule, write STUDY_DIR/results/",
                       description="Unblind the answers, leave out raters who fail the attention rule, and write "
                                   "the tables (CSV, markdown) and plots (PNG) to STUDY_DIR/results/.")
    r.add_argument("study_dir", help="folder made by `gesturelsm batch`")
    r.add_argument("--db", help="SQLAlchemy database URL (default: sqlite in STUDY_DIR/responses.sqlite)")
    r.add_argument("--out", help="output folder (default STUDY_DIR/results)")
    r.add_argument("--mismatch-pass", type=float, default=1.0,
                   help="fraction of mismatch checks a rater must pass (default 1.0: all)")
    r.add_argument("--repeat-pass", type=float, default=0.0,
                   help="fraction of repeat checks a rater must answer consistently (default 0: reported only, "
                        "as honest preferences between close methods change between repeats)")
    r.add_argument("--min-checks", type=int, default=1, help="attention checks a rater must have answered")
    r.add_argument("--keep-all", action="store_true", help="keep every rater (no attention rule)")
    r.add_argument("--reference", help="method whose Bradley-Terry score is 0 (default: the key's first)")
    r.add_argument("--bootstrap", type=int, default=2000, help="bootstrap resamples of raters")
    r.add_argument("--seed", type=int, default=0, help="seed of the bootstrap resamples")
    r.set_defaults(func=run_results)


def _folder(path: str) -> Path:
    d = Path(path)
    if not (d / "key" / "design.json").exists():
        raise UserError(f"{d} is not a study folder (no key/design.json); make one with `gesturelsm batch`")
    return d


def run_serve(args: argparse.Namespace) -> int:
    from ..study.server import serve

    if not 0 < args.port < 65536:
        raise UserError("--port must be from 1 to 65535")
    serve(_folder(args.study_dir), args.host, args.port, args.db)
    return 0


def run_invite(args: argparse.Namespace) -> int:
    from ..study.design import base_url, invite

    folder = _folder(args.study_dir)
    if args.n < 1:
        raise UserError("N, the number of raters to invite, must be at least 1")
    new = invite(folder, args.n, args.base_url)
    url = base_url(folder)
    for r in new:
        print(f"rater {r.id}: {url or ''}/r/{r.token}")
    print(f"{len(new)} rater link(s) added; every link is in {folder / 'key' / 'links.csv'}"
          + ("" if url else " (paths: put the study's address before them, or give --base-url)"))
    return 0


def run_results(args: argparse.Namespace) -> int:
    from ..study.results import Rule, analyse, markdown, write

    for name in ("mismatch_pass", "repeat_pass"):
        if not 0 <= getattr(args, name) <= 1:
            raise UserError(f"--{name.replace('_', '-')} must be a fraction from 0 to 1")
    rule = Rule(0.0, 0.0, 0) if args.keep_all else Rule(args.mismatch_pass, args.repeat_pass, args.min_checks)
    folder = _folder(args.study_dir)
    res = analyse(folder, args.db, rule, args.reference, args.bootstrap, args.seed)
    if not res.raters:
        print(f"no answers yet: hand each rater a link from {folder / 'key' / 'links.csv'} and serve the study "
              f"(`gesturelsm study serve {folder}`); nothing was written")
        return 1
    if not any(c.kept for c in res.raters):
        raise UserError(f"no rater passes the attention rule ({len(res.raters)} answered); "
                        "see --mismatch-pass, --repeat-pass, --keep-all")
    out = write(res, args.out or folder / "results", rule)
    print(markdown(res, rule))
    print(f"written to {out}")
    return 0
