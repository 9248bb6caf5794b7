"""Markdown tables for eval and bench reports, in the paper's layout, with the paper's numbers beside ours."""
from __future__ import annotations

from ..backends import label
from . import paper


def _f(v, fmt: str = "{:.3f}") -> str:
    return "-" if v is None else fmt.format(v)


def genea_lines(rep: dict) -> list[str]:
    """The GENEA Leaderboard's pose columns per row (docs/GENEA.md; the seeds of a clip are its samples)."""
    rows = [r for r in rep["rows"] if r.get("heldout")]
    if not rows:
        return []
    lines = ["", "GENEA Leaderboard pose columns (raw axis-angle poses, as its exp_eval_metrics.py; the seeds of a "
             "clip are its samples; DIV_sample needs 2 seeds or more):", "",
             "| method | steps | CFG | FD_g | FD_k | DIV_k | DIV_sample |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        h = r["heldout"]
        lines.append(f"| {label(r['method'])} | {r['steps']} | {r['cfg']:g} | "
                     + " | ".join(_f(h.get(k), "{:.4g}") for k in ("fid_g", "fid_k", "var_k", "sample_div")) + " |")
    return lines


def eval_markdown(rep: dict) -> str:
    ex = rep["extractors"]
    gt = rep.get("ground_truth") or {}
    fgd_cols = {"fgd_k": "FGD_k ↓", "fgd_g": "FGD_g ↓", "fgd_emage": "FGD (EMAGE AE) ↓"}
    head = ["method", "steps", "CFG", *[fgd_cols.get(e, e) for e in ex], "BC → (GT)", "Div ↑ (GT)",
            "expr MSE ↓", *(["face vertex MSE ↓"] if rep.get("face_vertices") else []), "jitter m/s³ (GT)",
            "foot skate cm/s (GT)", "s / clip", "RTF", "paper: FGD / BC / Div / AITS"]
    lines = [f"Held-out clips with ground truth ({sum(c['ground_truth'] for c in rep['clips'])}): "
             + ", ".join(f"{c['name']} ({c['seconds']} s)" for c in rep["clips"] if c["ground_truth"])
             + f"; {rep['seeds']} seed(s) each. {rep.get('policy', '')}. BC speeds normalised by "
             + f"{rep.get('bc_mean_speed', 'the ground truth')}.", "",
             "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    if gt:
        cells = ["ground truth", "-", "-", *["-" for _ in ex], _f(gt["bc"]), _f(gt["diversity"], "{:.2f}"), "-",
                 *(["-"] if rep.get("face_vertices") else []), _f(gt["jitter"], "{:.1f}"),
                 _f(gt["foot_skate"], "{:.1f}"), "-", "-",
                 f"- / {paper.GROUND_TRUTH['bc']} / {paper.GROUND_TRUTH['diversity']} / -"]
        lines.append("| " + " | ".join(cells) + " |")
    for r in rep["rows"]:
        h = r.get("heldout")
        if not h:
            continue
        p = paper.paper_row(r["method"], r["steps"])
        ptxt = "-" if p is None else " / ".join(_f(p.get(k), "{:.3f}") for k in ("fgd", "bc", "diversity", "aits"))
        ptxt += " *" if p and p.get("note") else ""
        cells = [label(r["method"]), str(r["steps"]), f"{r['cfg']:g}",
                 *[_f(h.get(e), "{:.4g}") for e in ex],
                 f"{_f(h['bc'])} ({_f(gt.get('bc'))})",
                 f"{_f(h['diversity'], '{:.2f}')} ({_f(gt.get('diversity'), '{:.2f}')})",
                 _f(h["expr_mse"], "{:.3f}"), *([_f(h["vertex_mse"], "{:.3g}")] if rep.get("face_vertices") else []),
                 f"{_f(h['jitter'], '{:.1f}')} ({_f(gt.get('jitter'), '{:.1f}')})",
                 f"{_f(h['foot_skate'], '{:.1f}')} ({_f(gt.get('foot_skate'), '{:.1f}')})",
                 _f(r["seconds_per_clip"], "{:.2f}"), _f(r["real_time_factor"], "{:.1f}x"), ptxt]
        lines.append("| " + " | ".join(cells) + " |")
    ao = [r for r in rep["rows"] if r.get("audio_only")]
    if ao:
        names = [c["name"] for c in rep["clips"] if not c["ground_truth"]]
        lines += ["", f"Audio-only takes ({', '.join(names)}): no ground-truth motion, so BC and diversity only.", "",
                  "| method | steps | CFG | BC | Div | jitter m/s³ | foot skate cm/s |",
                  "|---|---|---|---|---|---|---|"]
        for r in ao:
            a = r["audio_only"]
            lines.append(f"| {label(r['method'])} | {r['steps']} | {r['cfg']:g} | {_f(a['bc'])} | "
                         f"{_f(a['diversity'], '{:.2f}')} | {_f(a['jitter'], '{:.1f}')} | "
                         f"{_f(a['foot_skate'], '{:.1f}')} |")
    lines += amplitude_lines(rep)
    lines += feet_lines(rep)
    lines += genea_lines(rep)
    lines += ["", "FGD_k / FGD_g: Frechet distances of training-free kinetic / geometric joint features, z-scored by "
              "the ground truth's spread (lower is better; not on the paper's scale). BC: closer to ground truth is "
              "better. Div: metres, L1 over 55 joints x 3 axes. Paper: BEAT2 speaker 2 test set, EMAGE-AE FGD x 1e-1, "
              "AITS on an A100; * the paper's "
              "diffusion / rectified-flow rows (its Table 4c) do not state their steps, shown at 20 (DDIM's steps in "
              "the reference code)."]
    return "\n".join(lines)


def amplitude_lines(rep: dict) -> list[str]:
    """Wrist amplitude (metrics/amplitude.py: wrists relative to the pelvis, y up), held-out clips with ground
    truth and audio-only takes, ground truth beside."""
    gt = rep.get("ground_truth") or {}

    def cells(d: dict | None) -> str:
        if not d or d.get("raised_share") is None:
            return "- | - | - | -"
        return (f"{100 * d['raised_share']:.1f} % | {d['height_p95']:.2f} | {d['wrist_speed']:.2f} | "
                f"{d['hand_spread']:.2f}")

    out = ["", "Wrist amplitude (raised: a wrist above pelvis + 0.25 m; p95 wrist height above the pelvis, m; mean "
           "wrist speed, m/s; hand spread, m; means over clips x seeds):", "",
           "| method | steps | CFG | held-out: raised | p95 | speed | spread "
           "| audio-only: raised | p95 | speed | spread |",
           "|" + "---|" * 11, f"| ground truth | - | - | {cells(gt)} | - | - | - | - |"]
    for r in rep["rows"]:
        out.append(f"| {label(r['method'])} | {r['steps']} | {r['cfg']:g} | {cells(r.get('heldout'))} "
                   f"| {cells(r.get('audio_only'))} |")
    return out


FEET_COLUMNS = (("foot_skate", "foot skate cm/s", "{:.1f}"), ("contact_share", "contact", "{:.2f}"),
                ("drift_per_min", "drift m/min", "{:.2f}"), ("root_range", "range m", "{:.2f}"),
                ("bob", "bob cm", "{:.1f}"), ("penetration", "penetration cm", "{:.1f}"),
                ("leg_jerk", "leg jerk m/s³", "{:.1f}"))


def feet_lines(rep: dict) -> list[str]:
    """Feet and root (metrics/feet.py), held-out clips with ground truth then audio-only takes, ground truth first."""
    gt = rep.get("ground_truth") or {}
    if "contact_share" not in gt and not any("contact_share" in (r.get("heldout") or r.get("audio_only") or {})
                                             for r in rep["rows"]):
        return []
    head = ["method", "steps", "CFG", "clips", *(c[1] for c in FEET_COLUMNS)]
    out = ["", "Feet and root (metrics/feet.py; foot skate: ankles and feet within 5 cm of the take's floor; drift: "
           "start to end per minute; range: widest horizontal extent of the pelvis path; bob: spread of the pelvis "
           "height; penetration: p99 below the floor; means over clips x seeds):", "",
           "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]

    def row(name: str, steps: str, cfg: str, clips: str, d: dict | None) -> None:
        if d and d.get("contact_share") is not None:
            out.append("| " + " | ".join([name, steps, cfg, clips, *(_f(d.get(k), f) for k, _, f in FEET_COLUMNS)])
                       + " |")

    row("ground truth", "-", "-", "held-out", gt)
    for r in rep["rows"]:
        for part, clips in (("heldout", "held-out"), ("audio_only", "audio-only")):
            row(label(r["method"]), str(r["steps"]), f"{r['cfg']:g}", clips, r.get(part))
    return out


def bench_markdown(rep: dict) -> str:
    lines = [f"Machine: {rep['machine']}; torch threads {rep['threads']}; device {rep['device']}; "
             f"medians of {rep['repeats']} interleaved rounds. AITS = generation seconds (features + sampling + "
             f"decoding, transcript alignment excluded) per {rep['clip_seconds']:.2f} s clip "
             f"({rep['clip_frames']} frames, one window).", ""]
    head = ["preset", "method", "steps", "ms / step", "AITS (s)", "RTF 10 s", "RTF 60 s", "peak MB (60 s)",
            "measured on", "paper AITS (A100)"]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rep["rows"]:
        p = paper.paper_row(r["method"], r["steps"])
        lines.append("| " + " | ".join([
            r["preset"], label(r["method"]), str(r["steps"]), _f(r.get("ms_per_step"), "{:.1f}"),
            _f(r["aits"], "{:.3f}"), _f(r.get("rtf_10s"), "{:.1f}x"), _f(r.get("rtf_60s"), "{:.1f}x"),
            _f(r.get("peak_mb"), "{:.0f}"), r.get("hardware", rep.get("hardware", "-")),
            _f(p and p.get("aits"), "{:.3f}")]) + " |")
    if rep.get("ratios"):
        lines += ["", "Ratios (same run): " + "; ".join(f"{k}: {v:.2f}x" for k, v in rep["ratios"].items())]
    e2e = rep.get("end_to_end")
    if e2e:
        lines += ["", f"End to end (upload to video), {e2e['seconds_of_speech']:.1f} s of speech, "
                  f"{e2e['method']} {e2e['steps']} steps: "
                  + ", ".join(f"{k} {v:.2f} s" for k, v in e2e["stages"].items())
                  + f"; total {e2e['total']:.2f} s (first request after start: "
                    f"{e2e.get('first_request_total', float('nan')):.2f} s)."]
    if rep.get("process_peak_rss_mb"):
        lines += ["", f"Peak MB: extra resident memory during one 60 s generation (models loaded); whole process peak "
                      f"RSS {rep['process_peak_rss_mb']:.0f} MB."]
    return "\n".join(lines)
