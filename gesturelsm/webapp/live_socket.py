"""The Live tab's microphone transport: raw PCM over a WebSocket of the app's own server, motion pushed back.

Gradio's streaming microphone uploads every chunk as a file through its queue, which puts the speech seconds behind
the voice before any generation (docs/BENCHMARKS.md, "Why the code is built this way"). Here the page captures the
microphone
with an AudioWorklet (player/src/microphone.js `LiveMic`) and sends it as it comes, and the server sends each motion
chunk the moment the session's worker has it (no polling):

    client -> server   text   {"sample_rate": 16000}            first message (the AudioContext's rate); with
                              {"sample_rate": 16000, "character": TOKEN}  the page session's character token
                                                                 (live/characters.py), the stream is on that character
                              {..., "grounding": false}          feet on the ground off for this stream (default
                                                                 on: grounded causally, chunk by chunk)
    client -> server   binary int16 little-endian mono PCM       any length (the page sends 50 ms)
    client -> server   text   {"end": true}                     stop: the rest of the speech is generated, then closed
    server -> client   binary a motion record, no frames        only when the hello named a character, first: meta
                                                                 {"status": "streaming", "character": the player's spec
                                                                 (live/characters.py `CharacterStream.spec`, url, key)},
                                                                 or {"status": "streaming", "character_error": why}
                                                                 for a token the server does not hold (the mannequin)
    server -> client   binary a motion record                   per motion chunk (live.py `payload`; layout in
                                                                 gesturelsm/export/motion_codec.py): its meta's status
                                                                 is "streaming", then "stopped" or a message (busy,
                                                                 overloaded, bad input) and close

One socket is one LiveSession (gesturelsm/live/session.py): the LiveManager's limit applies (past it the visitor reads
the busy message), and a closed tab or a dropped connection stops the session at once. A session that ends by itself
(no audio for its idle timeout, or a failure) sends its reason and closes the socket; a socket that never names its
sample rate is closed after HELLO_TIMEOUT_S. Served at PATH (live.py: the page's player names it) by
`routes(manager, body)` (live.py `add_live_tab` returns it), passed to the FastAPI app when the page is launched
(ui.py).
"""
from __future__ import annotations

import asyncio
import json
import logging
from dataclasses import replace

import numpy as np
from starlette.routing import WebSocketRoute
from starlette.websockets import WebSocket, WebSocketDisconnect

from gesturelsm.audio import MAX_SAMPLE_RATE
from gesturelsm.errors import GestureError, InputError
from gesturelsm.export.motion_codec import MotionRecord, encode
from gesturelsm.live.session import LiveManager

from .live import PATH, payload, to_float
from ..live.characters import EXPIRED, CharacterStream

log = logging.getLogger(__name__)
RATES = (8000, MAX_SAMPLE_RATE)  # sample rates accepted from a page (an AudioContext's range is 3000-768000)
MAX_MESSAGE_S = 5.0             # longest audio in one message
HELLO_TIMEOUT_S = 10.0          # a socket that names no sample rate by then is closed
WATCH_S = 0.5                   # how often the sender checks that the session is still running


class MessageRefused(InputError):
    """A message the visitor's page should not have sent; the text says what was wrong."""


def hello(text: str) -> tuple[int, str | None]:
    """The sample rate and character token (None: none) of the first message (`{"sample_rate": 48000}`, optionally
    `"character": TOKEN`), checked."""
    try:
        d = json.loads(text)
        sr = int(d["sample_rate"])
    except (ValueError, TypeError, KeyError):
        raise MessageRefused('the first message must be {"sample_rate": <Hz>}') from None
    if not RATES[0] <= sr <= RATES[1]:
        raise MessageRefused(f"sample rate {sr} Hz is not supported (use {RATES[0]}-{RATES[1]} Hz)")
    token = d.get("character")
    if token is not None and not isinstance(token, str):
        raise MessageRefused("the character must be the token the page was given (a string)")
    return sr, token


def grounding_of(text: str) -> bool:
    """Whether the stream of this (checked) hello keeps its feet on the ground: its `grounding` (true / false),
    true when absent."""
    on = json.loads(text).get("grounding", True)
    if not isinstance(on, bool):
        raise MessageRefused("grounding must be true or false")
    return on


def pcm(data: bytes, sr: int) -> np.ndarray:
    """int16 little-endian mono PCM at `sr` -> (n,) float32 at 16 kHz."""
    if len(data) % 2:
        raise MessageRefused("audio messages must be 16-bit PCM (an even number of bytes)")
    if len(data) / 2 > MAX_MESSAGE_S * sr:
        raise MessageRefused(f"an audio message may hold at most {MAX_MESSAGE_S:g} s")
    return to_float(sr, np.frombuffer(data, "<i2"))


async def serve(ws: WebSocket, manager: LiveManager, body=None, characters=None) -> None:
    """One visitor's stream, from the socket's opening to its close; `characters` (live/characters.py
    `LiveCharacters`) resolves the hello's character token."""
    await ws.accept()
    loop = asyncio.get_running_loop()
    ready = asyncio.Event()
    session, pusher, character = None, None, None
    last = {"status": "streaming", "final": False, "closing": False}

    async def message(status: str) -> bytes:
        # off the event loop: on a character, retargeting and measuring the face take ~20 ms per chunk, which
        # would hold up every other visitor's socket
        return (await asyncio.to_thread(payload, session, status, body, character))[0]

    async def push() -> None:                   # motion out as soon as the worker publishes it; one sender only
        while True:
            try:
                await asyncio.wait_for(ready.wait(), WATCH_S)
            except asyncio.TimeoutError:
                if session.running or last["closing"]:
                    continue
                # the session ended by itself (no audio for its idle timeout, or generation failed): say so, close
                await say(ws, await message(session.error or "this live stream has ended"))
                await shut(ws)
                return
            ready.clear()
            final = last["final"]
            if not await say(ws, await message(last["status"])) or final:
                return

    async def finish(status: str, end: bool) -> None:
        """Send what is left (after generating the rest of the speech when `end`), with `status`, as the last
        message."""
        last["closing"] = True
        if end:
            await asyncio.to_thread(session.end, 10.0)
        else:
            session.stop()
        last.update(status=status, final=True)
        ready.set()
        await pusher

    try:
        try:
            first = await receive(ws, HELLO_TIMEOUT_S)
        except asyncio.TimeoutError:
            raise MessageRefused(f"no sample rate within {HELLO_TIMEOUT_S:g} s of connecting") from None
        text = first.get("text") or ""
        sr, token = hello(text)
        session = manager.open(replace(manager.config, grounding=grounding_of(text)),      # LiveBusy: said below
                               on_publish=lambda: loop.call_soon_threadsafe(ready.set))
        if token is not None:                   # before any motion: the page shows the character from frame 0
            character, meta = await asyncio.to_thread(stream_character, characters, token, body, grounding_of(text))
            if not await say(ws, encode(MotionRecord(meta=meta))):
                return
        pusher = asyncio.create_task(push())
        while True:
            msg = await receive(ws)
            try:
                if msg.get("bytes") is not None:
                    session.feed(pcm(msg["bytes"], sr))
                elif control(msg.get("text")).get("end"):
                    return await finish("stopped", end=True)
            except GestureError as exc:           # bad input, too slow, or the stream has ended
                return await finish(str(exc), end=False)
    except GestureError as exc:                   # a bad first message, or no free stream
        await say(ws, encode(MotionRecord(meta={"status": str(exc)})))
    except WebSocketDisconnect:                   # the tab closed or the network dropped mid-receive
        log.debug("live socket: the client left")
    finally:
        if pusher is not None and not pusher.done():
            pusher.cancel()
        if session is not None:
            session.stop()
        await shut(ws)


def stream_character(characters, token: str, body=None,
                     grounding: bool = True) -> tuple[CharacterStream | None, dict]:
    """The stream's character for the hello's `token` and the meta of the message that tells the page: its spec,
    or why the stream uses the mannequin; `grounding`: its feet planted on its own legs (live/characters.py)."""
    entry = characters.get(token) if characters is not None else None
    url = entry.serve() if entry is not None else None
    if url is None:
        return None, {"status": "streaming", "character_error": EXPIRED}
    try:
        stream = CharacterStream(entry.character, body, grounding=grounding)
    except GestureError as exc:                 # a character the retargeting refuses (e.g. an absurd scale)
        return None, {"status": "streaming", "character_error": f"{exc}; the live stream uses the mannequin"}
    return stream, {"status": "streaming", "character": {**stream.spec(), "url": url, "key": entry.key}}


async def receive(ws: WebSocket, timeout: float | None = None) -> dict:
    """The client's next message; WebSocketDisconnect when the client has gone, whether it said so or Starlette
    found the socket closed (RuntimeError). asyncio.TimeoutError after `timeout` seconds."""
    try:
        msg = await asyncio.wait_for(ws.receive(), timeout)
    except RuntimeError:
        raise WebSocketDisconnect() from None
    if msg["type"] == "websocket.disconnect":
        raise WebSocketDisconnect(msg.get("code", 1000))
    return msg


async def say(ws: WebSocket, message: str | bytes) -> bool:
    """Send `message` (text or a binary motion record); False when the client has gone (a visitor who leaves at any
    moment is a normal event, not a server error, so it is never raised into the ASGI server's log)."""
    try:
        await (ws.send_bytes(message) if isinstance(message, bytes) else ws.send_text(message))
        return True
    except (WebSocketDisconnect, RuntimeError):
        log.debug("live socket: the client left before a message could be sent")
        return False


async def shut(ws: WebSocket) -> None:
    """Close the socket unless the client has gone or closed it first (then there is nothing to close)."""
    try:
        await ws.close()
    except (WebSocketDisconnect, RuntimeError):
        pass


def control(text: str | None) -> dict:
    """A text message after the first: `{"end": true}`."""
    try:
        d = json.loads(text or "")
    except ValueError:
        raise MessageRefused('text messages must be JSON, e.g. {"end": true}') from None
    if not isinstance(d, dict):
        raise MessageRefused('text messages must be a JSON object, e.g. {"end": true}')
    return d


def routes(manager: LiveManager, body=None, characters=None) -> list[WebSocketRoute]:
    """The socket route for a FastAPI app (`Blocks.launch(app_kwargs={"routes": ...})`); `characters`: the page
    sessions' characters (live/characters.py `LiveCharacters`), None: the mannequin only."""
    async def endpoint(ws: WebSocket) -> None:
        await serve(ws, manager, body, characters)

    return [WebSocketRoute(PATH, endpoint)]
