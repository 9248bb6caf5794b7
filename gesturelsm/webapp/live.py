"""The Live tab: microphone chunks stream in, motion chunks and latency stream out as binary motion records.

    with gr.Blocks() as demo:
        ...
        routes = add_live_tab(LiveManager(pipe, max_sessions=2), body, cache,   # from ui.py, in the Blocks
                          socket_routes=live_socket.routes)
    demo.launch(app_kwargs={"routes": routes})                               # ui.py `launch` does this

With the player bundle built (the page's case), the tab is the in-browser player with Record / Stop buttons and the
meter, and the microphone goes over the app's own WebSocket (live_socket.py, served at PATH; it sends what
`payload` returns): raw PCM in 50 ms blocks, motion pushed back the moment it exists. Without the bundle (or for
`gradio_client` users: api_name "live_chunk" / "live_stop") it is Gradio's streaming microphone, one upload per
STREAM_EVERY_S, below.
Each stream gets its own `LiveSession` (gesturelsm/live/session.py), per socket or in a `gr.State`; it ends on the stop
button, when the tab closes (the socket closes, or Gradio deletes the state and the delete callback stops the
session), or when no audio arrived for the session's idle timeout (network drop). When all streams are taken the
visitor reads a "busy" line.
Each message is one record of the binary motion format (gesturelsm/export/motion_codec.py, decoded by its `decode`
and by the page's player/src/motion_decoder.js): the frames since the last message, numbered from `start`, and a
meta object {"frames": frames so far, "audio_seconds": audio received so far, "median_latency_ms", "p90_latency_ms",
"real_time_factor", "status"}. With a body (the page's) the frames are the in-browser player's arrays (kind
quaternion: 55 local rotations x, y, z, w, the root in metres, E expression weights;
gesturelsm/export/player_payload.py `motion_arrays`); without one, the generated SMPL-X motion (kind axis-angle: 55 x 3
poses and trans). With the visitor's character (live/characters.py: the socket's hello names the page session's token)
each record also carries the frames on the character (the format's version 2 character section); without one the
records are version 1. Over the socket a record is a binary message; Gradio's microphone puts it base64-encoded in the
hidden textbox `live-motion` (`decode(base64.b64decode(text))`).
The checkbox `live-grounding` (on by default) keeps the feet on the ground, causally, chunk by chunk (the stream's
`LiveConfig.grounding`; over the socket the hello's `grounding`), from the next Record on; on a character, on its own
legs. The element with id `live-latency` shows the median latency in milliseconds (just the number): from a microphone
chunk's arrival at the server to the motion covering it being ready; `live-stats` shows the p90 and the real-time
factor beside it. The player `live-player` (player/src/live_feed.js `LiveFeed`) plays the frames at 1x one steady
delay behind the voice and measures that delay itself (its data-shown-median-ms / data-shown-p90-ms); on the visitor's
character it carries data-character (the file name), like `motion-player`.
"""
from __future__ import annotations

import base64
from dataclasses import replace
from pathlib import Path
from typing import Callable

import gradio as gr
import numpy as np

from gesturelsm.audio import resample, to_mono
from gesturelsm.constants import SAMPLE_RATE
from gesturelsm.errors import GestureError
from gesturelsm.export.motion_codec import AXIS_ANGLE, QUATERNION, MotionRecord, encode
from gesturelsm.export.player_payload import motion_record
from gesturelsm.live.session import LiveBusy, LiveManager, LiveSession
from gesturelsm.motion.sequence import MotionSequence
from gesturelsm.motion.skeleton import NUM_JOINTS

PATH = "/gesturelsm/live"    # where the page's live player opens the app's WebSocket (live_socket.routes serves it)
STREAM_EVERY_S = 0.5     # s of microphone per upload: Gradio uploads each chunk as a file, and at 0.2 s the uploads
                         # fell 3-11 s behind the speech on the loaded 2-core machine (benchmarks/live_browser.py)
TIME_LIMIT_S = 15 * 60
GROUNDING_LABEL = "Feet on the ground"   # the Live tab's option (`live-grounding`): each stream from its start on


def to_float(sr: int, data: np.ndarray) -> np.ndarray:
    """A Gradio microphone chunk (int16 or float, mono or (n, channels)) -> (n,) float32 at 16 kHz."""
    y = np.asarray(data)
    if np.issubdtype(y.dtype, np.integer):
        y = y.astype(np.float32) / float(np.iinfo(y.dtype).max)
    return resample(to_mono(y.astype(np.float32)), int(sr), SAMPLE_RATE).astype(np.float32)


def payload(session: LiveSession, status: str, body=None, character=None) -> tuple[bytes, str, str]:
    """(the motion record for the player, text of #live-latency, text of #live-stats) from what the session produced
    since the last call; with `body` (a resolved body model) the record holds the in-browser player's arrays, with
    `character` (live/characters.py `CharacterStream`) also the same frames on the visitor's character."""
    chunks = session.poll()
    st = session.stats()
    start = chunks[0].start if chunks else session.delivered
    meta = {"frames": st["frames"], "audio_seconds": round(st["audio_seconds"], 3),
            "median_latency_ms": st["median_latency_ms"], "p90_latency_ms": st["p90_latency_ms"],
            "real_time_factor": st["real_time_factor"], "status": status}
    seq = MotionSequence(*(np.concatenate([getattr(c.motion, k) for c in chunks])
                           for k in ("poses", "trans", "expressions"))) if chunks else None
    if seq is not None and body is not None:        # only what the player draws
        record = motion_record(seq, body, start, meta)
    elif seq is not None:
        T = seq.num_frames
        record = MotionRecord(seq.poses.reshape(T, NUM_JOINTS, 3), seq.trans, np.zeros((T, 0)), kind=AXIS_ANGLE,
                              fps=seq.fps, start=start, meta=meta)
    else:
        record = MotionRecord(kind=QUATERNION if body is not None else AXIS_ANGLE,
                              rotations=np.zeros((0, NUM_JOINTS, 4 if body is not None else 3)), start=start, meta=meta)
    if seq is not None and character is not None:
        quats, root, morph = character.chunk(seq)
        record = replace(record, bone_rotations=quats, bone_root=root, morph=morph)
    return encode(record), _ms(st["median_latency_ms"]), _stats(st)


def as_text(record: bytes) -> str:
    """A record for Gradio's hidden textbox `live-motion` (base64)."""
    return base64.b64encode(record).decode("ascii")


def _ms(v: float | None) -> str:
    return "" if v is None else f"{v:.0f}"


def _stats(st: dict) -> str:
    """The line beside #live-latency: p90 latency and real-time factor since the stream started."""
    note = f" · {st['engines']}" if st.get("engines") else ""        # the operator's --vmc stream (live/relay.py)
    if st["p90_latency_ms"] is None:
        return note[3:]
    rtf = st["real_time_factor"]
    return f"p90 {st['p90_latency_ms']:.0f} ms · real-time factor {rtf:.1f}x · {st['frames']} frames{note}"


def on_chunk(manager: LiveManager, chunk, session: LiveSession | None, grounding: bool = True):
    """One microphone chunk: open a session on the first (its feet on the ground unless `grounding` is off), feed
    it, return what is ready (state, player JSON, #live-latency, #live-stats, status)."""
    if chunk is None:
        return session, gr.skip(), gr.skip(), gr.skip(), gr.skip()
    if session is None or not session.running:
        try:
            session = manager.open(replace(manager.config, grounding=bool(grounding)))
        except LiveBusy as exc:
            return None, as_text(encode(MotionRecord(meta={"status": str(exc)}))), "", "", str(exc)
    try:
        session.feed(to_float(*chunk))
        status = "streaming"
    except GestureError as exc:                 # too slow, audio it cannot use, or the stream has ended
        status = str(exc)
        session.stop()
    record, latency, stats = payload(session, status)
    return session, as_text(record), latency, stats, status


def on_stop(session: LiveSession | None):
    """The stop button (or the stream's time limit): generate the rest of the speech, then end the session."""
    if session is None:
        return None, gr.skip(), gr.skip(), gr.skip(), "stopped"
    session.end(timeout=10.0)
    record, latency, stats = payload(session, "stopped")
    return None, as_text(record), latency, stats, "stopped"


def _delete(session: LiveSession | None) -> None:
    if session is not None:
        session.stop()


def character_js() -> str:
    """The Character upload's last chained event: hands the page session's live spec (live/characters.py
    `LiveCharacters.choose`: token, name, url, key; null for the mannequin) to the live player, which uses it from the
    next Record on (gesturelsm/webapp/player/src/index.js `chooseLiveCharacter`)."""
    from .player.component import BUNDLE, file_url

    return ("(spec) => { import(new URL('" + file_url(BUNDLE) + "', document.baseURI).href)"
            ".then((m) => m.chooseLiveCharacter(spec || null)); }")


def live_player(body, cache: str | Path) -> gr.HTML | None:
    """The live player (element id `live-player`, same data-state / data-frames contract as `motion-player`) with
    its controls and meter, streaming over the app's WebSocket (live_socket.py), or None when the player bundle
    is not built. `cache`: folder for the rest body's GLB (shared with the page's)."""
    from gesturelsm.export.player_payload import body_glb
    from gesturelsm.motion.sequence import NUM_BETAS

    from .player.component import BUNDLE, file_url

    if not BUNDLE.exists():
        return None
    url = file_url(body_glb(body, np.zeros(NUM_BETAS, np.float32), cache))
    js = (f"import(new URL('{file_url(BUNDLE)}', document.baseURI).href)"
          ".then((m) => m.mountLive(element.querySelector('#live-player'), element))"
          ".catch((e) => { element.querySelector('#live-player').dataset.error = String(e); });")
    html = (f'<div id="live-player" data-state="empty" data-frames="0" data-frame="0" data-preload="{url}" '
            f'data-socket="{PATH.lstrip("/")}"></div>'
            '<div class="live-bar">'
            '<button id="live-record" type="button" class="lg primary">Record</button>'
            '<button id="live-stop" type="button" class="lg secondary" disabled>Stop</button>'
            f'<label class="live-option"><input id="live-grounding" type="checkbox" checked> {GROUNDING_LABEL}'
            '</label><span>median latency <b id="live-latency"></b> ms</span><span id="live-stats"></span>'
            '<span id="live-status"></span></div>')
    return gr.HTML("", html_template=html, js_on_load=js, elem_id="live-player-box", padding=False)


def add_live_tab(manager: LiveManager, body=None, cache: str | Path | None = None,
                 socket_routes: Callable[..., list] | None = None, characters=None) -> list:
    """Add the Live tab to the Blocks being built (call inside `with gr.Blocks()`); returns the routes to serve with
    the page (`Blocks.launch(app_kwargs={"routes": ...})`: ui.py `launch` does). With `body` (the page's body
    model), `cache` (where its rest GLB goes), `socket_routes` (`live_socket.routes`) and the player bundle built,
    the microphone streams over the app's WebSocket (its one route) and the motion plays in the in-browser player
    `live-player`; otherwise through Gradio's streaming microphone, shown as numbers (no routes). `characters`
    (live/characters.py `LiveCharacters`, the page sessions' characters) goes to the socket's route."""
    if body is not None:
        from gesturelsm.body.model import resolve_body

        body = resolve_body(body)
    with gr.Tab("Live"):
        gr.Markdown("Press record and speak: the body gestures with you, generated on this CPU while you talk, one "
                    f"steady delay behind your voice (it waits for {manager.config.lookahead * 4 / 30:.2g} s of the "
                    f"speech after each moment, and generates {manager.config.commit * 4 / 30:.2g} s of motion at a "
                    "time). Press stop to end the "
                    f"stream. At most {manager.max_sessions} live streams run at once.")
        socket = body is not None and cache is not None and socket_routes is not None
        if socket and live_player(body, cache) is not None:
            extra = {} if characters is None else {"characters": characters}
            return socket_routes(manager, body, **extra)   # the socket path: everything else is in the player's HTML
        state = gr.State(None, delete_callback=_delete)
        grounding = gr.Checkbox(True, label=GROUNDING_LABEL, elem_id="live-grounding")
        mic = gr.Audio(sources=["microphone"], streaming=True, type="numpy", label="microphone", elem_id="live-mic",
                       # no waveform: its drawing stalls the page
                       waveform_options=gr.WaveformOptions(show_recording_waveform=False))
        with gr.Row():
            latency = gr.Textbox(label="median latency (ms)", elem_id="live-latency", interactive=False)
            stats = gr.Textbox(label="since the stream started", elem_id="live-stats", interactive=False)
            status = gr.Textbox(label="status", elem_id="live-status", interactive=False)
        motion = gr.Textbox(visible=False, elem_id="live-motion",
                            label="motion chunk (base64 motion record)")   # for API clients
        outs = [state, motion, latency, stats, status]
        mic.stream(lambda microphone, s, g: on_chunk(manager, microphone, s, g), [mic, state, grounding], outs,
                   stream_every=STREAM_EVERY_S, time_limit=TIME_LIMIT_S, concurrency_limit=manager.max_sessions,
                   api_name="live_chunk", show_progress="hidden")
        mic.stop_recording(on_stop, [state], outs, api_name="live_stop")
    return []
