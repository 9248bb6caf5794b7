"""A study's design from the batch folder: which trials each rater sees, in which order, with which checks.

Study folder (written by `gesturelsm batch`, read by `gesturelsm study serve / results`):
    key/conditions.csv   video -> speech, method (the genuine conditions)
    key/mismatch.csv     attention-check videos: the motion of one clip (`motion_of`, a genuine video) with the
                         speech of another (`audio`)
    key/design.json      mode (pairwise | rating), attention rate, seed
    key/raters.json      rater id -> token and that rater's trial list (tokens are secrets: keep key/ private)
    key/links.csv        rater id, link path /r/<token> (hand one link to each rater)

Pairwise trials: every pair of methods on the same speech. Left/right is balanced within a rater (the shuffled
pairs alternate which method of the pair is left) and across raters (odd raters see every side swapped).
Rating trials: every genuine video once, rated on the 1-5 scales of SCALES (realness, synchrony, smoothness).
Attention checks, mixed in at `attention` (fraction of the real trials, at least one of each kind when > 0):
    mismatch   pairwise: a genuine video beside the same motion with another clip's speech; the genuine one
               passes. rating: the mismatched video alone; a synchrony rating at most 2 passes.
    repeat     a trial shown earlier, again later (sides swapped); the same video chosen (or none both times),
               or ratings within 1 point on every scale, passes.
"""
from __future__ import annotations

import csv
import json
import os
import secrets
from dataclasses import asdict, dataclass, field
from itertools import combinations
from pathlib import Path

import numpy as np

from ..errors import InputError, UserError

SCALES = ("realness", "synchrony", "smoothness")
SCALE_QUESTIONS = {
    "realness": "How human-like and natural do the gestures look? (1 = not at all, 5 = completely)",
    "synchrony": "How well do the gestures match the rhythm of the speech? (1 = not at all, 5 = perfectly)",
    "smoothness": "How smooth is the motion, free of jitter and jumps? (1 = very jerky, 5 = perfectly smooth)",
}
MODES = ("pairwise", "rating", "appropriateness")
KINDS = {"pairwise": "pair", "rating": "rating", "appropriateness": "pair"}
QUESTIONS = {"appropriateness": "Watch both videos with sound: the speech is the same, the movements differ. Whose "
                                "gestures fit this speech better?"}


@dataclass(frozen=True)
class Design:
    mode: str = "pairwise"
    attention: float = 0.15         # attention checks per real trial (half mismatch, half repeat)
    seed: int = 0

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise InputError(f"unknown study design {self.mode!r}; use one of {', '.join(MODES)}")
        if not 0 <= self.attention <= 1:
            raise UserError("--attention must be a fraction from 0 to 1")


@dataclass
class Trial:
    """One screen: `left` (and `right` for pairs) are video file names under videos/ (never sent to raters).
    check: '' for a real trial, 'mismatch' or 'repeat'; of: the repeated trial's index; expect: the side a
    mismatch check's genuine video is on (pairwise)."""
    index: int
    kind: str
    left: str
    right: str = ""
    check: str = ""
    of: int = -1
    expect: str = ""


@dataclass
class Rater:
    id: int
    token: str
    trials: list[Trial] = field(default_factory=list)


@dataclass
class Conditions:
    """What the key says: genuine video -> (speech, method); mismatch video -> (speech, motion_of video)."""
    genuine: dict[str, tuple[str, str]]
    mismatch: dict[str, tuple[str, str]]
    # appropriateness: video -> (speech heard, method, speech its motion was made for), the motion cut to the speech
    other: dict[str, tuple[str, str, str]] = field(default_factory=dict)

    @property
    def methods(self) -> list[str]:
        return list(dict.fromkeys(m for _, m in self.genuine.values()))


def _read_csv(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def read_conditions(study: str | Path) -> Conditions:
    """The key of a batch folder, keeping only videos that exist (a partial batch gives a smaller study)."""
    study = Path(study)
    path = study / "key" / "conditions.csv"
    if not path.exists():
        raise InputError(f"{study} is not a study folder made by `gesturelsm batch` (no key/conditions.csv)")
    have = lambda v: (study / "videos" / v).exists()   # noqa: E731
    rows = [r for r in _read_csv(path) if have(r["video"])]
    mismatched = lambda r: r.get("motion_of") not in (None, "", r["audio"])   # noqa: E731
    genuine = {r["video"]: (r["audio"], r["method"]) for r in rows if not mismatched(r)}
    other = {r["video"]: (r["audio"], r["method"], r["motion_of"]) for r in rows if mismatched(r)}
    mm = study / "key" / "mismatch.csv"
    mismatch = {r["video"]: (r["audio"], r["motion_of"]) for r in (_read_csv(mm) if mm.exists() else [])
                if have(r["video"]) and r["motion_of"] in genuine}
    return Conditions(genuine, mismatch, other)


def real_trials(cond: Conditions, design: Design) -> list[Trial]:
    """Every real trial in a fixed canonical order (pairs: first method of the key's order on the left)."""
    kind = KINDS[design.mode]
    if design.mode == "rating":
        return [Trial(0, kind, v) for v in cond.genuine]
    if design.mode == "appropriateness":
        return appropriateness_trials(cond)
    by_audio: dict[str, dict[str, str]] = {}
    for v, (a, m) in cond.genuine.items():
        by_audio.setdefault(a, {})[m] = v
    methods = cond.methods
    out = []
    for a, vids in by_audio.items():
        present = [m for m in methods if m in vids]
        out += [Trial(0, kind, vids[x], vids[y]) for x, y in combinations(present, 2)]
    if not out:
        raise InputError("a pairwise study needs at least two methods rendered for the same speech")
    return out


def appropriateness_trials(cond: Conditions) -> list[Trial]:
    """Per method and speech heard: the method's motion for that speech beside its motion for another speech (cut to
    the heard speech's length, played with it); matched on the left in this canonical order."""
    by = {(a, m): v for v, (a, m) in cond.genuine.items()}
    out = [Trial(0, "pair", by[(a, m)], v) for v, (a, m, _) in cond.other.items() if (a, m) in by]
    if not out:
        raise InputError("an appropriateness study needs, for some method, its videos of two speech files where "
                         "the other speech is at least as long as the one heard")
    return out


def rater_trials(cond: Conditions, design: Design, rater: int) -> list[Trial]:
    """Rater's trials: real trials shuffled with (seed, rater), sides balanced, checks mixed in."""
    rng = np.random.default_rng([design.seed, rater])
    base = real_trials(cond, design)
    trials = [base[i] for i in rng.permutation(len(base))]
    if KINDS[design.mode] == "pair":
        for j, t in enumerate(trials):
            if (j + rater) % 2:
                t.left, t.right = t.right, t.left
    n_checks = int(np.ceil(design.attention * len(trials))) if design.attention > 0 else 0
    mm_ok = bool(cond.mismatch) and design.mode != "appropriateness"    # there, mismatches are the question
    n_mismatch = (n_checks + 1) // 2 if mm_ok else 0
    n_repeat = n_checks - n_mismatch
    kind = KINDS[design.mode]
    checks: list[Trial] = []
    mm = list(cond.mismatch.items())
    for i in rng.permutation(len(mm))[:n_mismatch] if mm and n_mismatch else []:
        video, (_, motion_of) = mm[i]
        if design.mode == "rating":
            checks.append(Trial(0, kind, video, check="mismatch"))
        elif rng.random() < 0.5:
            checks.append(Trial(0, kind, motion_of, video, check="mismatch", expect="left"))
        else:
            checks.append(Trial(0, kind, video, motion_of, check="mismatch", expect="right"))
    # mismatch checks go into the second half; a repeat goes at least two trials after what it repeats
    order: list[Trial] = list(trials)
    for c in checks:
        order.insert(int(rng.integers(len(order) // 2, len(order) + 1)), c)
    repeats: list[tuple[Trial, Trial]] = []
    for src_i in rng.permutation(len(trials) // 2 or 1)[:min(n_repeat, len(trials))]:
        src = trials[int(src_i)]          # from the first half of the real trials, so the repeat is not adjacent
        rep = Trial(0, kind, src.right or src.left, src.left if src.right else "", check="repeat")
        j = next(k for k, o in enumerate(order) if o is src)
        order.insert(int(rng.integers(min(j + 2, len(order)), len(order) + 1)), rep)
        repeats.append((rep, src))
    for i, t in enumerate(order):
        t.index = i
    for rep, src in repeats:
        rep.of = src.index
    return order


def read_design(study: str | Path) -> Design:
    path = Path(study) / "key" / "design.json"
    if not path.exists():
        raise InputError(f"{study} has no study design (key/design.json); run `gesturelsm batch` first")
    return Design(**json.loads(path.read_text()))


def write_design(study: str | Path, design: Design) -> None:
    path = Path(study) / "key" / "design.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(asdict(design), indent=1) + "\n")


def read_raters(study: str | Path) -> dict[str, Rater]:
    """token -> Rater (empty when nobody is invited yet)."""
    path = Path(study) / "key" / "raters.json"
    if not path.exists():
        return {}
    raw = json.loads(path.read_text())
    out = {}
    for r in raw:
        rater = Rater(int(r["id"]), r["token"], [Trial(**t) for t in r["trials"]])
        out[rater.token] = rater
    return out


def base_url(study: str | Path, given: str | None = None) -> str | None:
    """The study's public address: `given` (checked: http(s)://HOST[:PORT][/PATH]), else the one an earlier
    invite wrote into key/links.csv's `url` column, else None."""
    if given:
        from urllib.parse import urlsplit

        parts = urlsplit(given.strip())
        if parts.scheme not in ("http", "https") or not parts.netloc or parts.query or parts.fragment:
            raise UserError(f"--base-url {given!r}: give the address raters open, like https://study.example.org "
                            "or http://192.168.1.5:8600")
        return given.strip().rstrip("/")
    path = Path(study) / "key" / "links.csv"
    if path.exists():
        for row in _read_csv(path):
            if row.get("url") and row.get("link") and row["url"].endswith(row["link"]):
                return row["url"][: -len(row["link"])]
    return None


def invite(study: str | Path, n: int, url: str | None = None) -> list[Rater]:
    """Add n raters with fresh unguessable tokens; their trial lists are fixed now (the key's videos may still
    grow). Returns the new raters; key/raters.json and key/links.csv are rewritten atomically. `url`: the study's
    public address: links.csv then has a `url` column with each rater's full link (also later, for every rater)."""
    if n < 1:
        raise UserError("the number of raters to invite must be at least 1")
    study = Path(study)
    url = base_url(study, url)
    design, cond = read_design(study), read_conditions(study)
    raters = read_raters(study)
    start = max((r.id for r in raters.values()), default=0) + 1
    new = []
    for rid in range(start, start + n):
        token = secrets.token_urlsafe(18)            # 144 random bits; a repeat is redrawn, never reused
        while token in raters or any(r.token == token for r in new):
            token = secrets.token_urlsafe(18)
        new.append(Rater(rid, token, rater_trials(cond, design, rid)))
    everyone = sorted([*raters.values(), *new], key=lambda r: r.id)
    _atomic_write(study / "key" / "raters.json",
                  json.dumps([dict(id=r.id, token=r.token, trials=[asdict(t) for t in r.trials]) for r in everyone]))
    _atomic_write(study / "key" / "links.csv", ("rater,link,url\n" if url else "rater,link\n") + "".join(
        f"{r.id},/r/{r.token}" + (f",{url}/r/{r.token}" if url else "") + "\n" for r in everyone))
    return new


def _atomic_write(path: Path, text: str) -> None:
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


__all__ = ["Conditions", "Design", "MODES", "QUESTIONS", "appropriateness_trials", "SCALES", "SCALE_QUESTIONS",
           "Rater", "Trial", "base_url", "invite", "read_conditions", "read_design",
           "read_raters", "rater_trials", "real_trials", "write_design"]
