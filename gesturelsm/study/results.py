"""`gesturelsm study results`: unblind the answers with the key, drop raters who fail the attention checks,
and write results/ in the study folder: CSV tables, results.md and results.png.

Attention rule (configurable): a rater is kept when they answered at least `min_checks` checks, chose the
genuine video (not the mismatched speech) in at least `mismatch_pass` of the mismatch checks, and answered at
least `repeat_pass` of the repeat checks as they answered the first time (0 by default: consistency is reported
per rater, but honest preferences between two close methods change between repeats, so it drops nobody unless
asked to).
Pairwise: per pair of methods, wins / losses / ties, the win rate without ties with a 95% Wilson interval, a
two-sided sign test with Holm's correction over all pairs; Bradley-Terry scores (reference method = 0) with
95% bootstrap intervals over raters. Rating: per method and scale, the mean with a 95% bootstrap interval.
Every row says how many raters and trials it rests on.
"""
from __future__ import annotations

import csv
import json
from dataclasses import dataclass, field
from itertools import combinations
from pathlib import Path

import numpy as np
from sqlalchemy.exc import DBAPIError

from ..errors import UserError
from . import appropriateness, db, stats
from .design import SCALES, Rater, Trial, read_conditions, read_design, read_raters
from .store import marker_key, missing_message, read_markers


@dataclass(frozen=True)
class Rule:
    mismatch_pass: float = 1.0
    repeat_pass: float = 0.0
    min_checks: int = 1

    def describe(self) -> str:
        return (f"a rater is kept with >= {self.min_checks} attention checks answered, >= {self.mismatch_pass:.0%} "
                f"of mismatch checks passed (genuine speech chosen) and >= {self.repeat_pass:.0%} of repeat checks "
                "answered consistently")


@dataclass
class RaterCheck:
    rater: int
    answered: int
    mismatch: tuple[int, int]      # passed, asked
    repeat: tuple[int, int]
    kept: bool
    reason: str = ""


@dataclass
class Results:
    mode: str
    methods: list[str]
    raters: list[RaterCheck]
    rows: list[dict] = field(default_factory=list)          # pairwise pairs, or rating means
    scores: list[dict] = field(default_factory=list)        # Bradley-Terry (pairwise only)
    ranking: list[str] = field(default_factory=list)        # by score (the plot's order)
    no_ranking: str = ""                                    # why the data cannot support a ranking ("" : it can)
    unclear: list[str] = field(default_factory=list)        # adjacent pairs of the ranking not told apart

    @property
    def kept(self) -> int:
        return sum(c.kept for c in self.raters)


def _chosen(t: Trial, answer: dict) -> str | None:
    return {"left": t.left, "right": t.right}.get(answer["choice"])


def check_rater(rater: Rater, answers: dict[int, dict], rule: Rule) -> RaterCheck:
    mm = rep = mm_ok = rep_ok = 0
    for t in rater.trials:
        a = answers.get(t.index)
        if a is None or not t.check:
            continue
        if t.check == "mismatch":
            mm += 1
            mm_ok += (a["choice"] == t.expect) if t.kind == "pair" else (a["ratings"]["synchrony"] <= 2)
        elif t.check == "repeat" and t.of in answers:
            rep += 1
            first, src = answers[t.of], rater.trials[t.of]
            if t.kind == "pair":
                rep_ok += _chosen(t, a) == _chosen(src, first)
            else:
                rep_ok += all(abs(a["ratings"][s] - first["ratings"][s]) <= 1 for s in SCALES)
    reasons = []
    if mm + rep < rule.min_checks:
        reasons.append(f"{mm + rep} checks answered")
    if mm and mm_ok < rule.mismatch_pass * mm:
        reasons.append(f"mismatch {mm_ok}/{mm}")
    if rep and rep_ok < rule.repeat_pass * rep:
        reasons.append(f"repeat {rep_ok}/{rep}")
    return RaterCheck(rater.id, len(answers), (mm_ok, mm), (rep_ok, rep), not reasons, ", ".join(reasons))


def read_answers(study: str | Path, url: str | None = None) -> list[dict]:
    """Every answer in the study's database, read without making or changing anything: a study nobody has
    answered yet has no database file, and gets none. A database that held answers and is gone is a UserError."""
    study = Path(study)
    full = url or db.default_url(study)
    file = db.sqlite_file(full)
    if file is not None and not file.exists():
        entry = read_markers(study).get(marker_key(url))
        if entry:
            raise UserError(missing_message(str(file), entry))
        return []
    try:
        return db.all_answers(db.open_db(full, create=False))
    except DBAPIError as exc:
        raise UserError(f"cannot read the answers database {file or marker_key(url)}: {exc.orig}") from None


def analyse(study: str | Path, url: str | None = None, rule: Rule = Rule(), reference: str | None = None,
            n_boot: int = 1000, seed: int = 0) -> Results:
    """The results of the study's answers (`Results.raters` is empty when no rater of the study answered)."""
    study = Path(study)
    design, cond = read_design(study), read_conditions(study)
    raters = {r.id: r for r in read_raters(study).values()}
    by_rater: dict[int, dict[int, dict]] = {}
    for a in read_answers(study, url):
        by_rater.setdefault(a["rater"], {})[a["trial"]] = a
    checks = [check_rater(raters[r], by_rater[r], rule) for r in sorted(by_rater) if r in raters]
    kept = [c.rater for c in checks if c.kept]
    methods = cond.methods
    if reference is not None and reference not in methods:
        raise UserError(f"--reference {reference!r} is not a method of this study ({', '.join(methods)})")
    res = Results(design.mode, methods, checks)
    if design.mode == "pairwise":
        _pairwise(res, [(raters[r], by_rater[r]) for r in kept], cond.genuine,
                  methods.index(reference) if reference else 0, n_boot, seed)
    elif design.mode == "appropriateness":
        res.rows = appropriateness.analyse([(raters[r], by_rater[r]) for r in kept], cond, n_boot, seed)
        res.ranking = [r["method"] for r in sorted(res.rows, key=lambda r: -np.nan_to_num(r["matched_share"],
                                                                                           nan=-1.0))]
        res.no_ranking = ("an appropriateness study tests each method against chance (50 %), not the methods "
                          "against each other")
    else:
        _rating(res, [(raters[r], by_rater[r]) for r in kept], cond.genuine, n_boot, seed)
    return res


def _pairwise(res: Results, kept: list, genuine: dict, ref: int, n_boot: int, seed: int) -> None:
    m = len(res.methods)
    idx = {x: i for i, x in enumerate(res.methods)}
    per_rater = np.zeros((max(1, len(kept)), m, m))
    ties = np.zeros((m, m))
    raters_on = np.zeros((m, m), int)
    for k, (rater, answers) in enumerate(kept):
        seen = np.zeros((m, m), bool)
        for t in rater.trials:
            a = answers.get(t.index)
            if a is None or t.check:
                continue
            i, j = idx[genuine[t.left][1]], idx[genuine[t.right][1]]
            seen[i, j] = seen[j, i] = True
            if a["choice"] == "none":
                ties[i, j] += 1
                ties[j, i] += 1
            else:
                w, lo = (i, j) if a["choice"] == "left" else (j, i)
                per_rater[k, w, lo] += 1
        raters_on += seen
    wins = per_rater.sum(0)
    pairs = list(combinations(range(m), 2))
    p = [stats.sign_test(int(wins[i, j]), int(wins[j, i])) for i, j in pairs]
    adj = stats.holm(p) if pairs else []
    for (i, j), pv, pa in zip(pairs, p, adj):
        n = wins[i, j] + wins[j, i]
        lo, hi = stats.wilson(wins[i, j], n)
        res.rows.append(dict(method_a=res.methods[i], method_b=res.methods[j], a_wins=int(wins[i, j]),
                             b_wins=int(wins[j, i]), ties=int(ties[i, j]), a_win_rate=wins[i, j] / n if n else
                             float("nan"), ci_low=lo, ci_high=hi, p=pv, p_holm=pa, raters=int(raters_on[i, j]),
                             trials=int(n + ties[i, j])))
    sc = stats.bt_bootstrap(per_rater, ref, n_boot, seed)
    elo, elo_boot = stats.elo(sc.score), stats.elo(sc.boot)
    elo_low, elo_high = np.quantile(elo_boot, 0.025, axis=0), np.quantile(elo_boot, 0.975, axis=0)
    for i, name in enumerate(res.methods):
        res.scores.append(dict(method=name, score=sc.score[i], ci_low=sc.low[i], ci_high=sc.high[i], elo=elo[i],
                               elo_low=elo_low[i], elo_high=elo_high[i],
                               raters=int(raters_on[i].max(initial=0)) if m > 1 else 0,
                               trials=int(wins[i].sum() + wins[:, i].sum() + ties[i].sum())))
    res.ranking = [res.methods[i] for i in np.argsort(-sc.score, kind="stable")]
    res.no_ranking = _unsupported(len(kept), res.rows)
    p_of = {frozenset((r["method_a"], r["method_b"])): r["p_holm"] for r in res.rows}
    res.unclear = [f"{a} vs {b}" for a, b in zip(res.ranking, res.ranking[1:])
                   if p_of.get(frozenset((a, b)), 1.0) >= 0.05]


MIN_RATERS = 2          # an interval over raters, and a ranking, need at least this many


def _unsupported(kept: int, rows: list[dict]) -> str:
    """What is missing for a ranking ("" when nothing is): raters kept, and comparisons of every pair by them."""
    if kept < MIN_RATERS:
        return (f"{kept} rater kept; intervals over raters and a ranking need at least {MIN_RATERS} (invite more "
                "raters: `gesturelsm study invite`)")
    thin = [f"{r['method_a']} vs {r['method_b']} ({r['raters']} rater{'s' * (r['raters'] != 1)}, "
            f"{r['trials']} comparison{'s' * (r['trials'] != 1)})" for r in rows if r["raters"] < MIN_RATERS]
    if thin:
        return f"pairs compared by fewer than {MIN_RATERS} raters: {', '.join(thin)}"
    return ""


def _rating(res: Results, kept: list, genuine: dict, n_boot: int, seed: int) -> None:
    for s in SCALES:
        for name in res.methods:
            groups = [np.array([answers[t.index]["ratings"][s] for t in rater.trials if not t.check
                                and t.index in answers and genuine[t.left][1] == name]) for rater, answers in kept]
            mean, lo, hi = stats.bootstrap_mean(groups, n_boot, seed)
            res.rows.append(dict(scale=s, method=name, mean=mean, ci_low=lo, ci_high=hi,
                                 raters=sum(len(g) > 0 for g in groups), trials=int(sum(len(g) for g in groups))))
    means = {name: np.mean([r["mean"] for r in res.rows if r["method"] == name]) for name in res.methods}
    res.ranking = sorted(res.methods, key=lambda x: -np.nan_to_num(means[x], nan=-np.inf))
    if len(kept) < MIN_RATERS:
        res.no_ranking = (f"{len(kept)} rater kept; intervals over raters and a ranking need at least {MIN_RATERS} "
                          "(invite more raters: `gesturelsm study invite`)")


def write(res: Results, out: str | Path, rule: Rule) -> Path:
    """results/ with raters.csv, pairwise.csv + scores.csv (or ratings.csv), results.md and results.png."""
    from .plots import plot_results

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    _csv(out / "raters.csv", [dict(rater=c.rater, answered=c.answered, mismatch_passed=c.mismatch[0],
                                   mismatch_asked=c.mismatch[1], repeat_consistent=c.repeat[0],
                                   repeat_asked=c.repeat[1], kept=c.kept, reason=c.reason) for c in res.raters])
    if res.mode == "pairwise":
        _csv(out / "pairwise.csv", res.rows)
        _csv(out / "scores.csv", res.scores)
    elif res.mode == "appropriateness":
        _csv(out / "appropriateness.csv", res.rows)
    else:
        _csv(out / "ratings.csv", res.rows)
    (out / "results.md").write_text(markdown(res, rule))
    plot_results(res, out / "results.png")
    (out / "summary.json").write_text(json.dumps(dict(mode=res.mode, ranking=[] if res.no_ranking else res.ranking,
                                                      no_ranking=res.no_ranking, not_told_apart=res.unclear,
                                                      kept=[c.rater for c in res.raters if c.kept]), indent=1))
    return out


def _csv(path: Path, rows: list[dict]) -> None:
    with open(path, "w", newline="") as fh:
        if rows:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in r.items()} for r in rows)


def markdown(res: Results, rule: Rule) -> str:
    kept = [c for c in res.raters if c.kept]
    lines = [f"# Study results ({res.mode})", "", f"Attention rule: {rule.describe()}.", "",
             f"Raters kept: {len(kept)} of {len(res.raters)}"
             + "".join(f"; rater {c.rater} dropped ({c.reason})" for c in res.raters if not c.kept) + ".", ""]
    if res.mode == "pairwise":
        lines += ["## Bradley-Terry scores and Elo (log-strength, reference = 0; Elo = 1000 + 400/ln 10 x (score - "
                  "mean score); 95% bootstrap over raters)", "",
                  "| rank | method | score | 95% interval | Elo | 95% interval | raters | trials |",
                  "|---|---|---|---|---|---|---|---|"]
        by = {s["method"]: s for s in res.scores}
        few = f"n/a ({len(kept)} rater)" if len(kept) < MIN_RATERS else ""
        for k, m in enumerate(res.ranking, 1):
            b = by[m]
            bt = few or f"[{b['ci_low']:+.2f}, {b['ci_high']:+.2f}]"
            el = few or f"[{b['elo_low']:.0f}, {b['elo_high']:.0f}]"
            lines.append(f"| {'-' if res.no_ranking else k} | {m} | {b['score']:+.2f} | {bt} | {b['elo']:.0f} | {el} | "
                         f"{b['raters']} | {b['trials']} |")
        lines += ["", "## Pairwise preference (ties left out of the win rate; sign test, Holm-corrected)", "",
                  "| A vs B | A wins | B wins | ties | A win rate [95% Wilson] | p | p (Holm) | raters | trials |",
                  "|---|---|---|---|---|---|---|---|---|"]
        lines += [f"| {r['method_a']} vs {r['method_b']} | {r['a_wins']} | {r['b_wins']} | {r['ties']} | "
                  f"{r['a_win_rate']:.2f} [{r['ci_low']:.2f}, {r['ci_high']:.2f}] | {r['p']:.3g} | {r['p_holm']:.3g}"
                  f"{' *' if r['p_holm'] < 0.05 else ''} | {r['raters']} | {r['trials']} |" for r in res.rows]
    elif res.mode == "appropriateness":
        lines += appropriateness.markdown(res.rows)
    else:
        lines += ["## Mean ratings (1-5; 95% bootstrap over raters)", "",
                  "| scale | method | mean | 95% interval | raters | trials |", "|---|---|---|---|---|---|"]
        lines += [f"| {r['scale']} | {r['method']} | {r['mean']:.2f} | [{r['ci_low']:.2f}, {r['ci_high']:.2f}] | "
                  f"{r['raters']} | {r['trials']} |" for r in res.rows]
    if res.mode == "appropriateness":
        lines += ["", f"Ranking: none; {res.no_ranking}.", ""]
    elif res.no_ranking:
        lines += ["", f"Ranking: none, the data cannot support one: {res.no_ranking}.", ""]
    else:
        lines += ["", "Ranking: " + " > ".join(res.ranking)
                  + (f" (not told apart at 5%, sign test with Holm's correction: {', '.join(res.unclear)})"
                     if res.unclear else ""), ""]
    return "\n".join(lines)


__all__ = ["Results", "Rule", "analyse", "check_rater", "markdown", "read_answers", "write"]
