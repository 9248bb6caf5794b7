"""results.png: Bradley-Terry scores with intervals and the pairwise win-rate matrix (pairwise studies), the
matched share per method (appropriateness studies), or mean ratings with intervals per scale (rating studies).
Drawn with matplotlib's Agg backend (no display)."""
from __future__ import annotations

from pathlib import Path

import numpy as np


def plot_results(res, path: str | Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if res.mode == "pairwise":
        fig, (ax, mx) = plt.subplots(1, 2, figsize=(9, 3.4), dpi=90, gridspec_kw=dict(width_ratios=[1.1, 1]))
        by = {s["method"]: s for s in res.scores}
        order = res.ranking[::-1]
        y = np.arange(len(order))
        score = np.array([by[m]["score"] for m in order])
        err = np.array([[by[m]["score"] - by[m]["ci_low"] for m in order],
                        [by[m]["ci_high"] - by[m]["score"] for m in order]])
        ax.errorbar(score, y, xerr=err, fmt="o", color="#1f5fa8", capsize=4)
        ax.axvline(0, color="#999", lw=0.8)
        ax.set_yticks(y, [f"{m}\n({by[m]['trials']} trials)" for m in order], fontsize=8)
        ax.set_xlabel("Bradley-Terry score (log-strength, 95% CI)")
        ax.set_title("Preference score", fontsize=10)
        m = len(res.methods)
        rate = np.full((m, m), np.nan)
        idx = {x: i for i, x in enumerate(res.methods)}
        for r in res.rows:
            i, j = idx[r["method_a"]], idx[r["method_b"]]
            rate[i, j], rate[j, i] = r["a_win_rate"], 1 - r["a_win_rate"]
        im = mx.imshow(rate, vmin=0, vmax=1, cmap="RdBu")
        for i in range(m):
            for j in range(m):
                if not np.isnan(rate[i, j]):
                    mx.text(j, i, f"{rate[i, j]:.2f}", ha="center", va="center", fontsize=8)
        mx.set_xticks(range(m), res.methods, rotation=30, fontsize=8)
        mx.set_yticks(range(m), res.methods, fontsize=8)
        mx.set_title("Row beats column (win rate)", fontsize=10)
        fig.colorbar(im, ax=mx, fraction=0.046)
    elif res.mode == "appropriateness":
        fig, ax = plt.subplots(figsize=(6, 0.6 + 0.5 * len(res.rows)), dpi=90)
        y = np.arange(len(res.rows))
        share = np.array([r["matched_share"] for r in res.rows])
        err = np.array([[r["matched_share"] - r["low"] for r in res.rows], [r["high"] - r["matched_share"]
                                                                          for r in res.rows]])
        ax.errorbar(share, y, xerr=np.nan_to_num(err), fmt="o", color="#1f5fa8", capsize=4)
        ax.axvline(0.5, color="#999", lw=0.8)
        ax.set_yticks(y, [f"{r['method']}\n({r['answers']} answers)" for r in res.rows], fontsize=8)
        ax.set_xlim(0, 1)
        ax.set_xlabel("share choosing the motion made for the speech heard (95% CI; 0.5 = chance)")
    else:
        scales = list(dict.fromkeys(r["scale"] for r in res.rows))
        fig, ax = plt.subplots(figsize=(7, 3.2), dpi=90)
        width = 0.8 / max(1, len(res.methods))
        for k, name in enumerate(res.methods):
            rows = [next(r for r in res.rows if r["scale"] == s and r["method"] == name) for s in scales]
            x = np.arange(len(scales)) + (k - (len(res.methods) - 1) / 2) * width
            mean = np.array([r["mean"] for r in rows])
            err = np.array([[r["mean"] - r["ci_low"] for r in rows], [r["ci_high"] - r["mean"] for r in rows]])
            ax.bar(x, mean, width, yerr=err, capsize=3, label=name)
        ax.set_xticks(range(len(scales)), scales)
        ax.set_ylim(1, 5)
        ax.set_ylabel("mean rating (95% CI)")
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return Path(path)
