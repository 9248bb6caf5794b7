"""The page's Sweep tab: methods x steps x CFG x seeds on one speech (gesturelsm.evaluation.sweep, the library
behind `gesturelsm sweep`), shown as a table with tooltips (`#sweep-table`), a plot of a chosen statistic against
generation time (`#sweep-plot`) and the CSV / markdown / JSON / PNG downloads; any run opens in the page's
in-browser player (`window.gesturelsmPlayer.load`). A progress bar carries the estimate of the time left; Cancel
stops the sweep before its next motion. The sweep itself is the service's (`GestureService.sweep`: the same checks,
transcript and request folders as Generate); sweeps share the generation queue with requests and are bounded by
`PAGE_LIMITS` (said in the tab).
"""
from __future__ import annotations

import html
import logging
import threading
from dataclasses import dataclass
from pathlib import Path

import gradio as gr

from gesturelsm.backends import label, ours_default
from gesturelsm.errors import GestureError
from gesturelsm.evaluation.motion_stats import BY_KEY, SEED_SPREAD, STATISTICS, format_value
from gesturelsm.evaluation.sweep import DEFAULT_CFGS, DEFAULT_STEPS, SweepLimits, SweepResult
from gesturelsm.evaluation.sweep_limits import measures
from gesturelsm.evaluation.sweep_report import PLOT_METRICS, sweep_plot
from gesturelsm.request_files import BODIES
from gesturelsm.serve.sweep import SweepRequest
from gesturelsm.settings import DEFAULTS
from gesturelsm.settings.schema import named

from .closing import PageWork
from .controls import page_control
from .language import language_choice
from .layout import SCROLL, TYPED_NOTE
from .player import component as motion_player

log = logging.getLogger("gesturelsm.app")
PAGE_LIMITS = SweepLimits(max_cells=36, max_seeds=3, max_work=720.0)
# hands a cell's payload to the player and brings the player into view (the tab sits below it)
OPEN_JS = ("(p) => { if (p && window.gesturelsmPlayer) { window.gesturelsmPlayer.load(p); "
           "document.querySelector('#motion-player')?.scrollIntoView({block: 'center'}); } }")


@dataclass
class PageSweep:
    """One finished sweep of a page: the result (with its motions), its folder and the speech file."""
    result: SweepResult
    folder: Path
    wav: Path | None


def table_html(result: SweepResult) -> str:
    """`#sweep-table`: time and statistics per cell (mean ± spread over seeds), the speaker's row last; its caption
    says what was measured (`evaluation.sweep.measures`: raw motion, grounded or not, unsmoothed)."""
    cols = [("time", "time", "s", "Generation time: sampling + decoding, features shared. Better: lower.")] + \
           [(s.key, s.label, s.unit, s.tooltip) for s in (*STATISTICS, SEED_SPREAD)]
    head = "<tr><th>method</th><th>steps</th><th>CFG</th>" + "".join(
        f'<th title="{html.escape(t)}" data-key="{k}">{html.escape(n)}<br><small>{html.escape(u)}</small></th>'
        for k, n, u, t in cols) + "</tr>"

    def cell(key: str, v: float, sd: float = float("nan")) -> str:
        text = f"{v:.3f}" if key == "time" else format_value(key, v)
        if sd == sd:                                           # not NaN
            text += f" ± {f'{sd:.3f}' if key == 'time' else format_value(key, sd)}"
        return f'<td data-key="{key}" data-value="{v!r}">{text}</td>'

    body = []
    for r in result.rows():
        body.append(f'<tr data-method="{r["method"]}" data-steps="{r["steps"]}" data-cfg="{r["cfg"]:g}">'
                    f'<td>{html.escape(label(r["method"]))}</td><td>{r["steps"]}</td><td>{r["cfg"]:g}</td>' +
                    "".join(cell(k, r[k], r.get(f"{k}_std", float("nan"))) for k, *_ in cols) + "</tr>")
    if result.reference is not None:
        st = result.reference.statistics
        body.append(f'<tr data-method="speaker" title="{html.escape(result.reference.source)}"><td>speaker '
                    f'(reference)</td><td></td><td></td><td></td>' +
                    "".join(cell(s.key, st[s.key]) for s in STATISTICS) + "<td></td></tr>")
    return (f'<div id="sweep-table" data-state="ready" data-cells="{len(result.rows())}"><div {SCROLL}><table>'
            f'<thead>{head}</thead><tbody>{"".join(body)}</tbody></table></div><p><small>'
            f'<span class="sweep-measures">Measured on {html.escape(measures(result.grounding))}.</span> '
            f"{len(result.runs)} motions of {result.speech_seconds:.1f} s in {result.seconds:.1f} s; mean ± standard "
            f"deviation over {result.grid.seeds} seed(s). Transcript: {html.escape(result.text_mode)}. Hover a heading "
            "for what it measures.</small></p></div>")


def run_labels(result: SweepResult) -> list[tuple[str, str]]:
    return [(f"{label(r.method)}, {r.steps} steps, CFG {r.cfg:g}, seed {r.seed}", str(i))
            for i, r in enumerate(result.runs)]


def _key(request: gr.Request | None) -> str:
    return request.session_hash if request is not None else ""


class SweepHandlers:
    def __init__(self, service, limits: SweepLimits = PAGE_LIMITS, pages: PageWork | None = None):
        self.service = service
        self.limits = limits
        self.pages = pages if pages is not None else PageWork()    # the page's: a closed tab stops its sweep
        self._stop: dict[str, threading.Event] = {}
        self._lock = threading.Lock()

    def _flag(self, request: gr.Request | None) -> threading.Event:
        with self._lock:
            return self._stop.setdefault(_key(request), threading.Event())

    @staticmethod
    def _refuse(msg: str):
        raise gr.Error(msg, duration=None, print_exception=False)

    def run(self, audio_path, methods, steps, cfgs, seeds, metric, text, auto_text=DEFAULTS.transcribe,
            language=DEFAULTS.language, request: gr.Request = None, progress=gr.Progress()):
        """-> table html, plot, downloads, run choices, state."""
        stop = self._flag(request)
        stop.clear()
        try:
            with self.pages.running(request) as closed:
                out = self.service.sweep(SweepRequest(audio_path, methods, steps, cfgs, seeds, metric, text,
                                                      transcribe=auto_text, language=language), self.limits,
                                         progress=lambda f, m: progress(f, desc=m),
                                         cancelled=lambda: stop.is_set() or closed.is_set())
        except GestureError as exc:
            if closed.is_set():                    # the tab closed: nobody to tell, nothing written
                log.info("a page closed during a sweep: the sweep stopped")
                return gr.skip(), gr.skip(), gr.skip(), gr.skip(), gr.skip()
            log.info("sweep refused: %s", " | ".join(str(exc).splitlines()))
            self._refuse(str(exc))
        finally:
            with self._lock:                       # a page's flag is kept only while its sweep runs
                if self._stop.get(_key(request)) is stop:
                    del self._stop[_key(request)]
        choices = run_labels(out.result)
        return (table_html(out.result), str(out.files["sweep.png"]), [str(p) for p in out.files.values()],
                gr.update(choices=choices, value=choices[0][1] if choices else None),
                PageSweep(out.result, out.folder, out.wav))

    def cancel(self, request: gr.Request = None) -> str:
        with self._lock:
            flag = self._stop.get(_key(request))
        if flag is not None:
            flag.set()
        return "Cancelled: the sweep stops before its next motion; nothing is written."

    def replot(self, state: PageSweep | None, metric: str):
        if state is None or metric not in BY_KEY:
            return gr.skip()
        return str(sweep_plot(state.result, state.folder / f"sweep-{metric}.png", metric))

    def open_run(self, state: PageSweep | None, run: str | None) -> dict | None:
        """The player's payload for one run of the sweep (written once into the sweep's folder)."""
        from gesturelsm.export.player_payload import Shown, Slot, player_payload

        if state is None or run is None:
            self._refuse("Run a sweep first, then choose one of its motions.")
        r = state.result.runs[int(run)]
        if r.motion is None:
            self._refuse("This sweep kept no motions to play.")
        shown = Shown((Slot(r.method, f"{label(r.method)} {r.steps} steps CFG {r.cfg:g} seed {r.seed}", r.motion),))
        return player_payload(shown, self.service.body, state.folder / f"run-{int(run)}",
                              self.service.workdir / BODIES, url=motion_player.file_url, audio=state.wav)


def typed_note(text: str | None):
    """Speech uploaded or recorded in the Sweep tab: words already in its transcript box stay, with a note."""
    if not (text or "").strip():
        return gr.update(value="", visible=False)
    return gr.update(value=TYPED_NOTE, visible=True)


def add_sweep_tab(service, limits: SweepLimits = PAGE_LIMITS, pages: PageWork | None = None) -> SweepHandlers:
    """The Sweep tab (call inside `with gr.Blocks()`, after the player); `pages`: the page's running work, which
    its unload stops (closing.py)."""
    h = SweepHandlers(service, limits, pages)
    methods = [m for m in service.methods if m in service.pipeline.methods]
    shown = [m for m in ours_default() if m in methods][:3]
    with gr.Tab("Sweep", elem_id="sweep-tab"):
        gr.Markdown("Tune steps and CFG by the numbers: every combination of the methods, step counts and CFG scales "
                    "is generated once per seed from this speech (its features computed once), timed and measured. "
                    f"Size of a sweep on this server: {limits.describe()}. The command line does the same with "
                    "`gesturelsm sweep` (docs/SWEEP.md)." + (f" {service.generation.sweep_note}"
                                                              if service.generation.sweep_note else ""))
        with gr.Row():
            with gr.Column(scale=1):
                audio = gr.Audio(sources=["upload", "microphone"], type="filepath", label="Speech",
                                 elem_id="sweep-speech")
                text = gr.Textbox(label="Transcript (optional: recognised automatically without it, as for Generate)",
                                  lines=2, elem_id="sweep-text")
                note = gr.Markdown(visible=False, elem_id="sweep-text-note")   # typed words kept for new speech
                # Generate's #auto-transcribe and #language, made from their fields (webapp/controls.py)
                auto_text = page_control(named("transcribe"), elem_id="sweep-auto-transcribe")
                language = language_choice("sweep-language")
                chosen = gr.CheckboxGroup([(label(m), m) for m in methods], value=shown, label="Methods",
                                          elem_id="sweep-methods")
                steps = gr.Textbox(" ".join(map(str, DEFAULT_STEPS)), label="Steps (space-separated)",
                                   elem_id="sweep-steps")
                cfgs = gr.Textbox(" ".join(f"{c:g}" for c in DEFAULT_CFGS), label="CFG scales (space-separated)",
                                  elem_id="sweep-cfg")
                seeds = gr.Number(1, precision=0, minimum=1, maximum=limits.max_seeds, label="Seeds per setting",
                                  elem_id="sweep-seeds")
                metric = gr.Dropdown([(BY_KEY[k].label, k) for k in PLOT_METRICS], value="wrist_speed",
                                     label="Statistic to plot against time", elem_id="sweep-metric")
                with gr.Row():
                    run = gr.Button("Run sweep", variant="primary", elem_id="sweep-run")
                    cancel = gr.Button("Cancel", elem_id="sweep-cancel")
                status = gr.Markdown(elem_id="sweep-status")
            with gr.Column(scale=2):
                table = gr.HTML('<div id="sweep-table" data-state="empty"></div>', elem_id="sweep-table-box",
                                label="sweep table (HTML)")
                plot = gr.Image(type="filepath", label="Statistic vs generation time", elem_id="sweep-plot",
                                interactive=False)
                with gr.Row():
                    pick = gr.Dropdown([], label="Open one motion of the sweep in the player above",
                                       elem_id="sweep-cell")
                    show = gr.Button("Open in player", elem_id="sweep-open", size="sm")
                files = gr.File(label="Sweep table and plot (CSV, markdown, JSON, PNG)", file_count="multiple",
                                elem_id="sweep-files")
        state, payload = gr.State(), gr.JSON(visible=False)
        run.click(h.run, [audio, chosen, steps, cfgs, seeds, metric, text, auto_text, language],
                  [table, plot, files, pick, state],
                       api_name="sweep", concurrency_limit=service.settings.concurrency, concurrency_id="generation")
        # words typed in the box are never used silently for other speech: a new upload or recording says so
        for changed in (audio.upload, audio.stop_recording):
            changed(typed_note, text, note, queue=False, api_visibility="private")
        text.input(lambda: gr.update(visible=False), None, note, queue=False, api_visibility="private")
        cancel.click(h.cancel, None, status, queue=False, api_visibility="private")
        run.click(lambda: "", None, status, queue=False, api_visibility="private")
        metric.change(h.replot, [state, metric], plot, api_visibility="private", show_progress="hidden")
        show.click(h.open_run, [state, pick], payload, api_name="sweep_open", api_visibility="private") \
            .then(None, payload, None, js=OPEN_JS)
    return h
