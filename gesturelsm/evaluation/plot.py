"""Quality vs inference time, like the paper's Figure 2: one line per method through its step counts."""
from __future__ import annotations

from pathlib import Path

from ..backends import color, label


def quality_time_plot(bench: dict, out: str | Path, evaluation: dict | None = None, metric: str = "fgd_k",
                      preset: str = "shipped") -> Path:
    """x: AITS (s per clip, log scale) from `bench`; y: `metric` of the held-out rows of `evaluation`
    (same method and steps), or the number of steps when no evaluation is given."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    quality = {}
    if evaluation:
        for r in evaluation["rows"]:
            h = r.get("heldout") or {}
            if h.get(metric) is not None:
                quality.setdefault((r["method"], r["steps"]), h[metric])
    fig, ax = plt.subplots(figsize=(6, 4.2), dpi=120)
    methods = []
    for r in bench["rows"]:
        if r["preset"] == preset and r["method"] not in methods:
            methods.append(r["method"])
    for m in methods:
        pts = sorted((r["steps"], r["aits"]) for r in bench["rows"] if r["preset"] == preset and r["method"] == m)
        if quality:
            pts = [(s, t, quality[(m, s)]) for s, t in pts if (m, s) in quality]
        else:
            pts = [(s, t, s) for s, t in pts]
        if not pts:
            continue
        xs, ys = [p[1] for p in pts], [p[2] for p in pts]
        ax.plot(xs, ys, "-o", color=color(m), label=label(m))
        for s, x, y in pts:
            ax.annotate(f"{s}", (x, y), textcoords="offset points", xytext=(4, 4), fontsize=8)
    ax.set_xscale("log")
    from matplotlib.ticker import FormatStrFormatter, NullFormatter

    ax.xaxis.set_major_formatter(FormatStrFormatter("%.3g"))
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel(f"inference time per clip, s (AITS, {bench.get('hardware', bench['device'])}, log scale)")
    ax.set_ylabel({"fgd_k": "FGD_k (kinetic features) ↓", "fgd_g": "FGD_g (geometric features) ↓",
                   "fgd_emage": "FGD (EMAGE AE) ↓"}.get(metric, metric) if quality else "sampling steps")
    ax.set_title("quality vs speed (labels: sampling steps)" if quality else "speed (labels: sampling steps)")
    ax.grid(alpha=0.3, which="both")
    ax.legend()
    fig.tight_layout()
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out)
    plt.close(fig)
    return out
