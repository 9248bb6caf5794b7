"""The server side of the Live tab: microphone chunks stream in, motion chunks and latency stream out as JSON.

    with gr.Blocks() as demo:
        ...
        add_live_tab(LiveManager(pipe, max_sessions=2))       # from app/ui.py, inside the Blocks

Each browser tab gets its own `LiveSession` (gesturelsm/live/session.py) in a `gr.State`; it ends on the stop
button, when the tab closes (Gradio deletes the state and the delete callback stops the session), or when no audio
arrived for the session's idle timeout (network drop). When all streams are taken the visitor reads a "busy" line.
The JSON for a player: {"start": first frame, "fps": 30, "poses": [[165 axis-angle] per frame], "trans": [[x, y, z]
per frame], "frames": frames so far, "median_latency_ms", "p90_latency_ms", "real_time_factor", "status"}.
The element with id `live-latency` shows the median latency in milliseconds (just the number).
"""
from __future__ import annotations

import json

import gradio as gr
import numpy as np

from gesturelsm.audio import resample, to_mono
from gesturelsm.live.session import LiveBusy, LiveManager, LiveOverloaded, LiveSession
from gesturelsm.live.stream import SR

STREAM_EVERY_S = 0.2
TIME_LIMIT_S = 15 * 60


def to_float(sr: int, data: np.ndarray) -> np.ndarray:
    """A Gradio microphone chunk (int16 or float, mono or (n, channels)) -> (n,) float32 at 16 kHz."""
    y = np.asarray(data)
    if np.issubdtype(y.dtype, np.integer):
        y = y.astype(np.float32) / float(np.iinfo(y.dtype).max)
    return resample(to_mono(y.astype(np.float32)), int(sr), SR).astype(np.float32)


def payload(session: LiveSession, status: str) -> tuple[str, str]:
    """(JSON for the player, text of #live-latency) from what the session produced since the last call."""
    chunks = session.poll()
    st = session.stats()
    data = {"start": chunks[0].start if chunks else session.delivered, "fps": 30,
            "poses": np.concatenate([c.motion.poses for c in chunks]).round(4).tolist() if chunks else [],
            "trans": np.concatenate([c.motion.trans for c in chunks]).round(4).tolist() if chunks else [],
            "frames": st["frames"], "median_latency_ms": st["median_latency_ms"],
            "p90_latency_ms": st["p90_latency_ms"], "real_time_factor": st["real_time_factor"], "status": status}
    med = st["median_latency_ms"]
    return json.dumps(data), ("" if med is None else f"{med:.0f}")


def on_chunk(manager: LiveManager, chunk, session: LiveSession | None):
    """One microphone chunk: open a session on the first, feed it, return what is ready."""
    if chunk is None:
        return session, gr.skip(), gr.skip(), gr.skip()
    if session is None or not session.running:
        try:
            session = manager.open()
        except LiveBusy as exc:
            return None, json.dumps({"status": str(exc)}), "", str(exc)
    try:
        session.feed(to_float(*chunk))
        status = "streaming"
    except (LiveOverloaded, RuntimeError) as exc:
        status = str(exc)
        session.stop()
    js, lat = payload(session, status)
    return session, js, lat, status


def on_stop(session: LiveSession | None):
    if session is None:
        return None, gr.skip(), gr.skip(), "stopped"
    session.end(timeout=10.0)
    js, lat = payload(session, "stopped")
    return None, js, lat, "stopped"


def _delete(session: LiveSession | None) -> None:
    if session is not None:
        session.stop()


def add_live_tab(manager: LiveManager) -> gr.Tab:
    """Add the Live tab to the Blocks being built (call inside `with gr.Blocks()`)."""
    with gr.Tab("Live") as tab:
        gr.Markdown("Speak into the microphone: the body gestures with you, generated on this CPU as you talk. "
                    f"At most {manager.max_sessions} live streams run at once.")
        state = gr.State(None, delete_callback=_delete)
        mic = gr.Audio(sources=["microphone"], streaming=True, type="numpy", label="microphone")
        with gr.Row():
            latency = gr.Textbox(label="median latency (ms)", elem_id="live-latency", interactive=False)
            status = gr.Textbox(label="status", elem_id="live-status", interactive=False)
        motion = gr.Textbox(visible=False, elem_id="live-motion")            # JSON for the player
        mic.stream(lambda c, s: on_chunk(manager, c, s), [mic, state], [state, motion, latency, status],
                   stream_every=STREAM_EVERY_S, time_limit=TIME_LIMIT_S, concurrency_limit=manager.max_sessions,
                   api_name="live_chunk")
        mic.stop_recording(on_stop, [state], [state, motion, latency, status], api_name="live_stop")
    return tab
