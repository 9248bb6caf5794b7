"""A sweep's table (CSV, markdown, JSON) and its plot of one statistic against generation time, written together
into one folder: into a temporary folder beside it first, then moved in, so a failed or cancelled sweep leaves
no half-written files."""
from __future__ import annotations

import csv
import io
import json
import shutil
import tempfile
from pathlib import Path

import numpy as np

from ..errors import InputError
from .motion_stats import BY_KEY, SEED_SPREAD, STATISTICS, format_value
from ..backends import color, label
from .sweep import SweepResult
from .sweep_limits import PLOT_METRICS, measures

FILES = ("sweep.csv", "sweep.md", "sweep.json", "sweep.png")
if PLOT_METRICS != tuple(s.key for s in (*STATISTICS, SEED_SPREAD)):
    raise ImportError("sweep_limits.PLOT_METRICS must list the keys of motion_stats.STATISTICS and SEED_SPREAD")
MARKERS = "osD^vP*X"


def csv_text(result: SweepResult) -> str:
    keys = ["time", *(s.key for s in STATISTICS)]
    head = ["method", "steps", "cfg", "seeds"] + [c for k in keys for c in (k, f"{k}_std")] + ["seed_spread"]
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(head)
    for r in result.rows():
        w.writerow([r["method"], r["steps"], f"{r['cfg']:g}", r["seeds"]] +
                   ["" if not np.isfinite(r[c]) else f"{r[c]:.6g}" for c in head[4:]])
    if result.reference is not None:
        st = result.reference.statistics
        w.writerow(["speaker", "", "", ""] + [c for k in keys for c in
                   (("" if k == "time" else f"{st[k]:.6g}"), "")] + [""])
    return buf.getvalue()


def _cell(r: dict, key: str) -> str:
    v, sd = r[key], r.get(f"{key}_std", float("nan"))
    s = f"{v:.3f}" if key == "time" else format_value(key, v)
    return s + (f" ± {(f'{sd:.3f}' if key == 'time' else format_value(key, sd))}" if np.isfinite(sd) else "")


def markdown_text(result: SweepResult) -> str:
    g = result.grid
    head = ["method", "steps", "CFG", "time (s)", *(f"{s.label} ({s.unit})" for s in STATISTICS),
            f"{SEED_SPREAD.label} ({SEED_SPREAD.unit})"]
    lines = [f"Measured on {measures(result.grounding)}.", "",
             f"Sweep on {result.speech_seconds:.1f} s of speech ({result.text_mode}); {g.seeds} seed(s) per setting, "
             f"mean ± standard deviation over seeds; generation time is sampling + decoding (features shared); "
             f"whole sweep {result.seconds:.1f} s.", "",
             "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in result.rows():
        lines.append("| " + " | ".join([label(r["method"]), str(r["steps"]), f"{r['cfg']:g}", _cell(r, "time"),
                                        *(_cell(r, s.key) for s in STATISTICS),
                                        format_value("seed_spread", r["seed_spread"])]) + " |")
    if result.reference is not None:
        st = result.reference.statistics
        lines.append("| speaker (reference) | - | - | - | " + " | ".join(format_value(s.key, st[s.key])
                                                                         for s in STATISTICS) + " | - |")
        lines += ["", f"Speaker row: {result.reference.source}."]
    lines += ["", "Columns:"] + [f"- **{s.label}** ({s.unit}): {s.tooltip}" for s in (*STATISTICS, SEED_SPREAD)]
    return "\n".join(lines)


def sweep_plot(result: SweepResult, out: str | Path, metric: str = "wrist_speed") -> Path:
    """`metric` (mean over seeds, bars: spread) against generation time (log scale when it spans more than a
    decade), one line per method and CFG
    through its step counts (labels: steps); the speaker's value as a dashed line when it has one."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FormatStrFormatter, NullFormatter

    if metric not in BY_KEY:
        raise InputError(f"unknown statistic {metric!r}; choose one of {', '.join(PLOT_METRICS)}")
    stat = BY_KEY[metric]
    rows = result.rows()
    fig, ax = plt.subplots(figsize=(6.4, 4.2), dpi=100)
    for mi, m in enumerate(result.grid.methods):
        for ci, c in enumerate(result.grid.cfgs):
            pts = sorted((r["time"], r[metric], r.get(f"{metric}_std", np.nan), r["steps"]) for r in rows
                         if r["method"] == m and r["cfg"] == c and np.isfinite(r[metric]))
            if not pts:
                continue
            x, y, e, s = (np.array(v) for v in zip(*pts))
            ax.errorbar(x, y, yerr=np.where(np.isfinite(e), e, 0), color=color(m, f"C{mi}"),
                        marker=MARKERS[ci % len(MARKERS)], alpha=0.55 + 0.45 * (ci + 1) / len(result.grid.cfgs),
                        capsize=2, label=f"{label(m)}, CFG {c:g}")
            for xi, yi, si in zip(x, y, s):
                ax.annotate(str(si), (xi, yi), textcoords="offset points", xytext=(3, 3), fontsize=7)
    if result.reference is not None and metric in result.reference.statistics:
        ax.axhline(result.reference.statistics[metric], color="k", ls="--", lw=1, label="speaker")
    times = [r["time"] for r in rows if np.isfinite(r["time"]) and r["time"] > 0]
    log_x = bool(times) and max(times) / min(times) > 10           # a log axis only where it spans a decade
    if log_x:
        ax.set_xscale("log")
        ax.xaxis.set_major_formatter(FormatStrFormatter("%.3g"))
        ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel(f"generation time for {result.speech_seconds:.1f} s of speech, s{' (log scale)' if log_x else ''}")
    ax.set_ylabel(f"{stat.label} ({stat.unit})")
    ax.set_title(f"{stat.label} vs time (labels: steps); better: {stat.better}", fontsize=8)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7, ncol=2 if len(result.grid.cfgs) * len(result.grid.methods) > 6 else 1)
    fig.tight_layout()
    out = Path(out)
    fig.savefig(out)
    plt.close(fig)
    return out


def sweep_json(result: SweepResult) -> dict:
    g = result.grid
    return {"grid": {"methods": list(g.methods), "steps": list(g.steps), "cfg": list(g.cfgs), "seeds": g.seeds},
            "grounding": result.grounding,
            "speech_seconds": result.speech_seconds, "text_mode": result.text_mode, "seconds": result.seconds,
            "measures": measures(result.grounding), "rows": result.rows(),
            "runs": [{"method": r.method, "steps": r.steps, "cfg": r.cfg, "seed": r.seed, "time": r.seconds,
                      **r.statistics} for r in result.runs],
            "speaker": None if result.reference is None else {"source": result.reference.source,
                                                              **result.reference.statistics},
            "statistics": {s.key: {"label": s.label, "unit": s.unit, "better": s.better, "what": s.what}
                           for s in (*STATISTICS, SEED_SPREAD)}}


def _finite(v):
    """NaN -> None, recursively, so that sweep.json is strict JSON."""
    if isinstance(v, dict):
        return {k: _finite(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_finite(x) for x in v]
    if isinstance(v, (float, np.floating)):
        return float(v) if np.isfinite(v) else None
    return v


def write_sweep(result: SweepResult, out: str | Path, metric: str = "wrist_speed") -> dict[str, Path]:
    """FILES into `out` (created; same-named files replaced), written in a temporary sibling folder first."""
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}-", dir=out.parent))
    try:
        (tmp / "sweep.csv").write_text(csv_text(result))
        (tmp / "sweep.md").write_text(markdown_text(result) + "\n")
        (tmp / "sweep.json").write_text(json.dumps(_finite(sweep_json(result)), indent=1) + "\n")
        sweep_plot(result, tmp / "sweep.png", metric)
        if not out.exists():
            tmp.chmod(0o755)                 # mkdtemp's folder is private; the output folder is not
            tmp.rename(out)
        else:
            for f in FILES:
                (tmp / f).replace(out / f)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return {f: out / f for f in FILES}
