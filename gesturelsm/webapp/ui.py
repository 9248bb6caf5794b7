"""The page: Gradio Blocks over `gesturelsm.serve.service.GestureService` (no logic of its own).

`build_demo(service)` builds everything inside the function, so tests can build and drive it, and returns a
`demo.Demo`: the Blocks with the live streams and socket routes that run beside it (`Demo.launch` serves them,
`Demo.close` stops them). The main action is exposed to `gradio_client` as `api_name="/generate"` (see README,
"Web app").
"""
from __future__ import annotations

import contextlib
import json
import logging
import threading
from collections import OrderedDict
from pathlib import Path

import gradio as gr

from gesturelsm.constants import ASSETS
from gesturelsm.errors import GestureError
from gesturelsm.serve.config import QUEUE_SIZE
from gesturelsm.serve.lifetime import gradio_delete_cache
from gesturelsm.request_files import BODIES
from gesturelsm.serve.request import DEFAULT_SIZE, TIMING_COLUMNS, VIDEO_SIZES, Request, Result
from gesturelsm.serve.service import GestureService
from gesturelsm.settings import page_params, settings_of

from . import edit_section, live, live_socket, stats_view, sweep_tab, videos
from .layout import TIMING_WIDTHS as WIDTHS
from .aside import aside
from .character import character_upload, choose, rig_downloads
from .closing import PageWork
from .controls import controls_of
from .demo import Demo
from .downloads import Downloads
from . import words as page_words
from ..live.characters import LiveCharacters
from .page_params import make_request, page_handler
from .player import component as motion_player
from .raw_inputs import numeric_choices

log = logging.getLogger("gesturelsm.app")
LIVE_STREAMS = 2                # live microphone streams at once (each takes ~1/4 of a core); more get "busy"

EXAMPLES = Path(__file__).resolve().parent / "examples"
MODEL_CARD = ASSETS / "MODEL_CARD.md"

INTRO = """# GestureLSM: speech to gestures
Record or upload speech, optionally give the transcript, and watch a body gesture with it, next to baselines.
Runs on a plain CPU; the body is a built-in mannequin (SMPL-X layout) unless a real SMPL-X model is configured."""

HOW_IT_WORKS = """**How it works.** The speech is turned into an amplitude envelope and onset track; if you give a
transcript, each word is timed against the audio (eSpeak NG + DTW, in its language's voice), or taken from your
TextGrid, and embedded with MiniLM; with neither, the speech is **transcribed automatically** (offline; Whisper tiny.en,
base for other languages) and the recognised words appear in the transcript box to correct and run again; untick
*Transcribe automatically* and the model runs **audio-only**, as for Chinese and Japanese words (shown, not used: the
text encoder is English). A spatial-temporal transformer then samples latent codes of four body regions (upper body,
hands, lower body, face) with **shortcut flow matching** (GestureLSM): a few steps are enough. *Rectified flow* and
*DDIM* are the baselines trained the same way with their usual objectives. Per-region RVQ-VAE decoders turn the latents
into SMPL-X joint rotations at 30 fps, which are rendered offscreen and muxed with your speech. *CFG* is classifier-free
guidance on the speech; *seed* picks the noise, so the same seed gives the same motion.
*Feet on the ground* (on by default) plants each foot where it lands (leg IK), keeps the body from drifting away and
puts it on the floor, for every method and ground truth, without touching the upper body; *stand in place* removes
horizontal root movement; *smoothing* is a Savitzky-Golay filter on the joint rotations. Timings: each where it was
spent (*made ahead*: before the click); features, alignment and transcription are computed once for all methods; the
real-time factor is speech seconds per generation second (alignment, transcription and rendering excluded, as in the
paper); an edit has its own row; the last row is the whole request: all its methods and the one video's render time."""


def _limits() -> str:
    try:
        text = MODEL_CARD.read_text()
    except OSError:
        return "The model card (assets/MODEL_CARD.md) is missing."
    i = text.find("## What the models can and cannot do")
    return text[i:].replace("## ", "**", 1).replace("do\n", "do**\n", 1) if i >= 0 else text


def _examples() -> list[list]:
    try:
        meta = json.loads((EXAMPLES / "examples.json").read_text())
    except (OSError, ValueError):
        return []
    return [[str(EXAMPLES / m["audio"]), m["text"]] for m in meta if (EXAMPLES / m["audio"]).exists()]


class _Handlers:
    """The page's event handlers over one service; each turns the service's errors into one message."""

    def __init__(self, service: GestureService):
        self.service = service
        # page session -> the folder of its newest request: a render still running (or queued) for an older request
        # of that page is stopped, since the page already shows newer bodies (see show_video)
        self.newest: OrderedDict[str, str] = OrderedDict()
        self._lock = threading.Lock()
        self.downloads = Downloads()
        self.pages = PageWork(service.renders)      # each page's videos and running work, stopped when it closes
        self.session_ended = self.pages.session_ended      # Gradio's unload (closing.py)

    def mark_newest(self, request: gr.Request | None, out: Result | None) -> None:
        if request is None or out is None:
            return
        with self._lock:
            before = self.newest.get(request.session_hash)
            self.newest[request.session_hash] = out.job.folder
            self.newest.move_to_end(request.session_hash)
            while len(self.newest) > 10000:
                self.newest.popitem(last=False)
        if before is not None and before != out.job.folder:     # newer bodies on the page: its older video goes
            self.service.renders.supersede(request.session_hash)

    def _replaced(self, request: gr.Request | None, out: Result) -> bool:
        """A newer request of the same page exists (its bodies are on screen): this one's video is not needed."""
        if request is None:
            return False
        with self._lock:
            newest = self.newest.get(request.session_hash)
        return newest is not None and newest != out.job.folder

    @staticmethod
    def request(sent: dict, *, exports: bool, render: bool = True) -> Request:
        """Values exactly as sent, by the page's parameters: the service checks and normalises every field
        (gesturelsm.serve.checks)."""
        return make_request(sent, exports=exports, render=render)

    @staticmethod
    def refuse(exc: GestureError):
        """The one place the page turns errors into messages: one log line, no traceback (server bugs keep theirs)."""
        log.info("request refused: %s", " | ".join(str(exc).splitlines()))
        raise gr.Error(str(exc), duration=None, print_exception=False) from None

    def _run(self, req: Request, progress) -> Result:
        try:
            return self.service.run(req, progress=lambda f, m: progress(f, desc=m))
        except GestureError as exc:
            self.refuse(exc)

    @staticmethod
    def download_files(out: Result):
        return [str(p) for p in out.downloads], (str(out.glb) if out.glb else None)

    @page_handler("words", optional_from="grounding")
    def prefetch(self, sent: dict, words=None) -> None:
        """Speech uploaded or recorded (or its transcript or settings changed): decode it and prepare the speech
        (features, transcript, word timings) while the visitor chooses the settings, so Generate only generates
        (serve/prepared.py), then make the motion the settings on screen ask for, for a click that asks for the same
        (serve/ahead.py). Silent: the request reports problems."""
        sent = {**sent, "text": page_words.own_words(sent["audio"], sent["text"], words)}
        ahead = self.request(sent, exports=False, render=False)
        self.service.prefetch(sent["audio"], sent["text"] or "", sent["textgrid"], bool(ahead.transcribe), ahead=ahead)

    @page_handler("character", "words", optional_from="grounding", request=True, progress=True)
    def show_motion(self, sent: dict, character=None, words=None, request: gr.Request = None, progress=None):
        """The page's button: the motions for the in-browser player, timings, summary and the recognised transcript,
        sent again each time a method is made (`GestureService.stream`: the player shows every method's body the
        moment its motion exists, on the page session's `character` when one is loaded); the video (`show_video`)
        and the downloads (`add_exports`) follow in chained events. (Parameters are named, not *args: Gradio passes
        the request and progress only to positional parameters.) `words`: the page's recognised words (words.py)."""
        sent = {**sent, "text": page_words.own_words(sent["audio"], sent["text"], words)}
        req, audio = self.request(sent, exports=False, render=False), sent["audio"]
        try:
            for out in self.pages.until_closed(request, progress, lambda p: self.service.stream(req, progress=p)):
                self.mark_newest(request, out)
                shown = motion_player.payload(self.service, out, character)
                if out.previews:     # a longer preview of a method being made: the player's payload alone (redrawing
                    yield shown, gr.skip(), gr.skip(), out, gr.skip(), gr.skip(), gr.skip()   # the unchanged boxes
                    continue                                        # cost the browser what the first body needs)
                recognised = out.transcript if out.transcript else gr.skip()   # the automatic transcript, to correct
                yield (shown, out.table, out.summary, out, recognised, page_words.recognised(audio, out),
                       page_words.status(out))
        except GestureError as exc:
            self.refuse(exc)

    def _kept(self, request: gr.Request | None, out: Result):
        """`out` for the page's state, unless a newer request of the page replaced it (the state holds that one)."""
        return gr.skip() if self._replaced(request, out) else out

    def show_video(self, out: Result | None, character=None, request: gr.Request = None, progress=gr.Progress()):
        """`video_steps` run to its end (`progress(fraction, desc=...)`: where the video is meanwhile)."""
        return videos.last(self.video_steps(out, character, request, progress))

    def video_steps(self, out: Result | None, character=None, request: gr.Request = None, progress=None):
        """The video in the server's render queue, the summary saying where it is (`videos.steps`)."""
        yield from videos.steps(self, out, character, request, progress)

    def made_downloads(self, out: Result | None, request: gr.Request = None):
        """npz and BVH of each method made so far, while the others are generated; `add_exports` adds the rest."""
        if out is None or not out.motions or out.downloads or self._replaced(request, out):
            return gr.skip()            # never fewer than add_exports' list, however late (downloads.py)
        return self.downloads.made_so_far(out.job.folder, lambda: aside(self.service.export_each, out))

    def add_exports(self, out: Result | None, character=None, request: gr.Request = None):
        """The downloads, before the video (never behind one); with a character, each motion in its own file too."""
        if out is None or self._replaced(request, out):  # a newer request replaced it: its own chain exports
            return gr.skip(), gr.skip(), gr.skip(), gr.skip()
        with self.downloads.completing(out.job.folder) as remember:
            out = self.service.export(out)
            files, glb = self.download_files(out)
            files += [str(p) for p in rig_downloads(character, out.motions, out.job.folder, self.service.body,
                                                    out.job.grounding)]
            remember(files)
        return files, glb, out.summary, self._kept(request, out)

    @page_handler(optional_from="auto_text", progress=True)
    def generate(self, sent: dict, progress=None):
        """The API (`/generate`): everything in one call."""
        out = self._run(self.request(sent, exports=True), progress)
        return (str(out.video), out.table, out.summary, *self.download_files(out))


def _input_column(service: GestureService) -> tuple[list, gr.Button, gr.File, gr.Markdown]:
    """Speech, transcript and settings (each setting's control as its field says: `webapp/controls.py`, for this
    server's methods); returns the request's inputs in the handlers' order (`page_params`), the button, the Character
    upload, the note."""
    make = controls_of(service)                    # each setting's control as its field says (webapp/controls.py)
    # the browser's own audio player: Gradio's waveform decodes and draws the whole upload on the page's main thread
    # (0.1-0.4 s measured) just as the visitor clicks Generate and the first body is fetched (docs/WEBAPP.md)
    audio = gr.Audio(sources=["upload", "microphone"], type="filepath", label="Speech (record or upload)",
                     elem_id="speech", waveform_options=gr.WaveformOptions(show_recording_waveform=False))
    text = gr.Textbox(label="Transcript (optional: words are timed automatically)", lines=3,
                      placeholder="Type what is said, or leave empty to transcribe the speech automatically",
                      elem_id="transcript")
    note = gr.Markdown(visible=False, elem_id="transcript-note")     # typed words kept for new speech (words.py)
    auto_text, language = make("auto_text"), make("language")
    textgrid = gr.File(label="Word timings as a TextGrid (optional, instead of automatic timing)",
                       file_types=[".TextGrid", ".textgrid"], type="filepath")
    methods = make("methods")
    character = character_upload()
    with gr.Row():
        steps, cfg = make("steps"), make("cfg")
    with gr.Row():
        ddim_steps, seed = make("ddim_steps"), make("seed")
    with gr.Accordion("Options", open=False):
        grounding, in_place, smoothing = make("grounding"), make("in_place"), make("smoothing")
        size = numeric_choices(gr.Dropdown([(f"{s} x {s} per body", s) for s in VIDEO_SIZES], value=DEFAULT_SIZE,
                                           label="Video size"), VIDEO_SIZES)
        controls = dict(audio=audio, text=text, textgrid=textgrid, methods=methods, steps=steps, cfg=cfg, seed=seed,
                        ddim_steps=ddim_steps, in_place=in_place, smoothing=smoothing, size=size, auto_text=auto_text,
                        grounding=grounding, language=language)
        controls |= {s.param: make(s.param) for s in settings_of() if s.param not in controls}   # a setting's own
    button = gr.Button("Generate gestures", variant="primary", elem_id="generate")
    ex = _examples()
    if ex:
        gr.Examples(ex, inputs=[audio, text], label="Examples (synthetic speech, with transcripts)")
    return [controls[p] for p in page_params()], button, character, note


def _output_column(service: GestureService) -> tuple:
    """Player (with the status line and the Edit section under it), video, summary, timings, downloads, GLB viewer:
    (payload, video, summary, table, files, view, show3d, stats, edit, status)."""
    motion_player.player_component(service)
    status = gr.Markdown(elem_id="generate-status", container=False, label="status")   # what it does (words.status)
    edit = edit_section.component()
    payload = gr.JSON(visible=False, label="motion for the in-browser player")
    # With the in-browser player (its bundle built), the player shows the motion and the mp4 is for download and
    # sharing. A <video> on screen, even paused, holds headless Chromium's software-composited page at ~20 redraws
    # per second (the player with it), so it opens on request (benchmarks/player_latency.py measures the player).
    with (gr.Accordion("Video with the speech (mp4, rendered on the server after the motion plays)", open=False,
                       elem_id="video-box") if motion_player.BUNDLE.exists() else contextlib.nullcontext()):
        video = gr.Video(label="Gestures with your speech", show_label=False, elem_id="video", autoplay=False)
    summary = gr.Markdown(elem_id="summary", label="summary")
    table = gr.Dataframe(headers=TIMING_COLUMNS, interactive=False, elem_id="timings", wrap=True, column_widths=WIDTHS,
                         label="Timing per method and stage (each heading gives its unit; real-time factor = "
                               "speech seconds per generation second)")
    stats = stats_view.component()                 # motion statistics per method, filled after the player starts
    files = gr.File(label="Downloads: npz (BEAT2 / SMPL-X), BVH, GLB, keypoints, ARKit face CSV",
                    file_count="multiple", elem_id="downloads")
    # Mounted only when asked for: its viewer redraws continuously (it would slow the player's software WebGL), and a
    # viewer mounted hidden (e.g. in a closed accordion) and given its file there draws nothing when shown later.
    show3d = gr.Button("Show the first method's GLB in an interactive 3D viewer", size="sm", elem_id="view3d-show")
    view = gr.Model3D(label="Interactive 3D view (animated GLB of the first method)", height=420, elem_id="view3d",
                      visible=False)
    return payload, video, summary, table, files, view, show3d, stats, edit, status


# Runs in the browser before the GLB is requested (Gradio awaits it): waits until the viewer shown by the step
# before is mounted and laid out (then two animation frames), so the file never reaches an unmounted viewer.
VIEWER_MOUNTED_JS = """async (...args) => {
    const shown = () => { const v = document.querySelector('#view3d'); return v && v.getClientRects().length > 0; };
    for (let t0 = Date.now(); !shown() && Date.now() - t0 < 20000;) await new Promise((r) => setTimeout(r, 50));
    for (let i = 0; i < 2; i++) await new Promise((r) => requestAnimationFrame(r));
    return args; }"""


def build_demo(service: GestureService, queue_size: int = QUEUE_SIZE, engines=None) -> Demo:   # engines: --vmc
    settings = service.settings
    h = _Handlers(service)
    gen = {"concurrency_limit": settings.concurrency, "concurrency_id": "generation"}   # one generation pool
    # videos in a pool of their own: generating again never waits behind one; every video step is let in, the
    # service's render queue (serve/renders.py) renders them in turn, says each one's place and cancels a closed page's;
    # the downloads in a pool of their own. "multiple": a newer request's step is queued while an older one's is pending
    render = {"concurrency_limit": None, "concurrency_id": "render", "trigger_mode": "multiple"}
    exports = {"concurrency_limit": settings.concurrency, "concurrency_id": "exports", "trigger_mode": "multiple"}
    with gr.Blocks(title="GestureLSM demo", delete_cache=gradio_delete_cache(settings.keep_minutes)) as demo:
        gr.Markdown(INTRO)
        with gr.Row():
            with gr.Column(scale=1):
                inputs, button, upload, note = _input_column(service)
            with gr.Column(scale=2):
                payload, video, summary, table, files, view, show3d, stats, edit, status = _output_column(service)
        manager, routes, characters = None, [], LiveCharacters(service.workdir, motion_player.file_url,
                                                                body=service.body)
        if "gesturelsm" in service.pipeline.methods:            # the Live tab streams the GestureLSM generator
            manager = live.LiveManager(service.pipeline, LIVE_STREAMS, threads=settings.threads, relay=engines)
            service.set_busy(lambda: manager.active > 0)          # live streams keep their cores (serve/ahead.py)
            routes = live.add_live_tab(manager, body=service.body, cache=service.workdir / BODIES,
                                       socket_routes=live_socket.routes, characters=characters)
        sweep_tab.add_sweep_tab(service, pages=h.pages)
        with gr.Accordion("How it works, and the model's limits", open=False):
            gr.Markdown(HOW_IT_WORKS)
            gr.Markdown(_limits())
            gr.Markdown(f"Limits of this server: speech up to {settings.max_seconds / 60:g} minutes, uploads up to "
                        f"{settings.max_upload_mb:g} MB, {settings.concurrency} request(s) at a time (others wait "
                        f"in the queue); files are deleted after {settings.keep_minutes:g} minutes.")
        text, state, character = inputs[1], gr.State(), gr.State()     # character: the page session's (None: mannequin)
        chosen = upload.change(choose, upload, [character, upload], api_visibility="private")
        if routes:              # the Live tab's player streams on the same character: the socket gets it by a token
            token, spec = gr.State(None, delete_callback=characters.drop), gr.JSON(visible=False)
            chosen.then(characters.choose, [character, token], [token, spec], api_visibility="private") \
                .then(None, spec, None, js=live.character_js())
        # before the click: the upload's speech prepared (serve/prepared.py), the settings' motion made (serve/ahead.py)
        words = page_words.attach(inputs, note, h.prefetch)          # each upload its own words; prefetch
        shown = button.click(h.show_motion, [*inputs, character, words], [payload, table, summary, state, text, words,
                             status], api_name="generate_motion", js=page_words.CLICK_JS,
                             show_progress_on=[status], **gen)
        # every payload a handler sends (Generate's, one per method made; an edit's; an undo's) goes to the player at
        # once, in the browser; the statistics and the downloads made so far follow it, beside the chain below
        payload.change(None, payload, None, js=motion_player.LOAD_JS, api_visibility="private")
        stats_view.attach(payload.change, state, stats)
        payload.change(h.made_downloads, state, files, api_visibility="private", show_progress="hidden",
                       concurrency_limit=1, concurrency_id="downloads", trigger_mode="always_last")

        def follow(event, named: bool = False) -> None:     # after Generate, an edit or an undo (motions in state)
            # the downloads first, in a pool of their own (never behind anybody's video), then the video; the status
            # line says "Ready" once the video came (a failed step ends the chain: no claim of a video that failed)
            event.then(h.add_exports, [state, character], [files, view, summary, state],
                       api_name="add_exports" if named else None, api_visibility="private", **exports) \
                .then(h.video_steps, [state, character], [video, table, summary, state],
                      api_name="show_video" if named else None, api_visibility="private", show_progress="hidden",
                      **render) \
                .then(lambda: page_words.READY, None, status, queue=False, api_visibility="private")
        follow(shown, named=True)
        edit_section.attach(edit, h, shown, state, character, dict(payload=payload, table=table, summary=summary,
                                                                   video=video, files=files), follow)
        glb = gr.State()                               # the file is handed over only once the viewer is mounted
        show3d.click(lambda out: (gr.update(visible=True, value=None), out), state, [view, glb], queue=False,
                     api_visibility="private") \
            .then(lambda out: str(out.glb) if out is not None and out.glb else None, glb, view, queue=False,
                  js=VIEWER_MOUNTED_JS, api_visibility="private")
        api_button = gr.Button(visible=False)          # the stable API endpoint: all outputs from one call
        api_button.click(h.generate, inputs, [video, table, summary, files, view], api_name="generate", **gen)
        demo.unload(h.session_ended)                   # a closed page's videos are cancelled (serve/renders.py)
    demo.queue(max_size=queue_size, default_concurrency_limit=settings.concurrency)
    return Demo(demo, service, live=manager, routes=routes)


def serve_locally(service: GestureService, queue_size: int = QUEUE_SIZE) -> tuple[Demo, str]:
    """Build and serve the app in this process on a free port of 127.0.0.1 (tests and dev tools);
    returns the Demo (close it when done) and the URL."""
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    demo = build_demo(service, queue_size)
    demo.launch(port=port, prevent_thread_lock=True, quiet=True)
    return demo, f"http://127.0.0.1:{port}"
