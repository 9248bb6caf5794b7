"""The visitor's character in the Live tab, server side: the live socket streams the motion on the character the page
session chose with the Character upload (webapp/character.py), retargeted chunk by chunk. No page code here: the page
gives the address its files are loaded at (`url`).

    characters = LiveCharacters(workdir, url, body=body)   # one per server (ui.py); the live socket gets it too;
                                                           # url(path): the address the page loads a file at
    token, spec = characters.choose(character, old_token)  # the upload's event: the page session keeps the token,
                                                           # the page's live player gets `spec` (token, name, url, key)
    entry = characters.get(token)                          # the live socket's hello names the token: LiveEntry / None
    stream = CharacterStream(entry.character, body)        # per live stream
    stream.spec()                                          # the page's JSON: name, bones, nodes, align, scale, head
    quats, root, morph = stream.chunk(seq)                 # (T, B, 4), (T, 3), (T, F): this chunk, continuing

The socket is not a Gradio event, so it cannot read the page session's gr.State: the page hands the socket a random
token instead (never a path), which this map resolves to the Character the upload's event read. An entry is dropped
when its page session ends (the token's gr.State delete callback), when the session chooses another character or
clears it, after TTL_S without use, or when MAX_ENTRIES newer ones exist. The character file the page's player loads
is a copy in a request folder of the server's workdir (`req-...`, swept like the request outputs; copied again
when a stream starts after a sweep).

Retargeting a stream chunk by chunk gives what retargeting the whole stream gives (gesturelsm.retarget): the
rotations are per frame, the root motion keeps the first chunk's reference (`Ground`: where the pelvis started, where
SMPL-X's floor is), and each bone's quaternion keeps the sign of its previous frame across chunk borders. With
`grounding` (on unless the stream's is off) its feet are planted on its own legs causally, chunk by chunk
(gesturelsm/retarget/grounding.py `CharacterStreamGrounder`): what the same grounder gives the whole stream at once.
A VRM with viseme / blink expressions also moves its face: `spec()["morphs"]` lists the morph-target channels
(character.py `face_channels`, [[glTF mesh, target], ...]; [] for none) and each chunk's `morph` holds their weights
for the chunk's frames (character.py `face_morph`: per frame, with one Blinker for the stream, so per chunk is the
whole motion's at those frames).
"""
from __future__ import annotations

import hashlib
import os
import secrets
import shutil
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from ..body.model import resolve_body
from ..export.alive import Blinker
from ..export.character_payload import bone_order, face_channels, face_morph
from ..export.glb import continuous_quaternions, matrix_to_quaternion_xyzw
from ..motion.sequence import MotionSequence
from ..request_files import request_name
from ..retarget import Character, Ground, SourceBody, retarget
from ..retarget.grounding import CharacterStreamGrounder
from ..retarget.solve import prepare

TTL_S = 6 * 3600          # an entry unused this long is dropped (its page session has long gone quiet)
MAX_ENTRIES = 64          # characters held at once (each holds its parsed file); the oldest go first
EXPIRED = "the chosen character is no longer on the server (choose it again); the live stream uses the mannequin"


@dataclass
class LiveEntry:
    character: Character
    key: str                       # a hash of the file's bytes: the browser parses one file once
    folder: Path                   # the request folder holding the copy the page loads
    url: Callable[[Path], str]     # the address the page loads a file of the server's at
    used: float = field(default_factory=time.monotonic)

    @property
    def served(self) -> Path:
        return self.folder / f"character{self.character.path.suffix.lower()}"

    def serve(self) -> str | None:
        """The copy's URL (copied again if a sweep removed it and the upload is still there); None when neither is."""
        try:
            if not self.served.is_file():
                self.folder.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(self.character.path, self.served)
            os.utime(self.folder)                       # fresh for the sweeper
        except OSError:
            return None
        return self.url(self.served)


class LiveCharacters:
    """Page session tokens -> the character each chose (thread-safe; see the module docstring)."""

    def __init__(self, workdir: str | Path, url: Callable[[Path], str], ttl_s: float = TTL_S,
                 max_entries: int = MAX_ENTRIES, body=None):
        """`url(path)`: the address the page loads a file of the server's at (the page's own, e.g. Gradio's file
        route); `body`: the server's body model (None: the built-in one), which the at-rest spec is measured on."""
        self.workdir, self.url, self.ttl_s, self.max_entries = Path(workdir), url, ttl_s, max_entries
        self.body = body
        self._entries: OrderedDict[str, LiveEntry] = OrderedDict()
        self._lock = threading.Lock()

    def register(self, character: Character) -> str:
        """A new token for `character` (its file copied where the page can load it)."""
        return self._add(character)[0]

    def _add(self, character: Character) -> tuple[str, LiveEntry]:
        entry = LiveEntry(character, hashlib.sha1(character.path.read_bytes()).hexdigest(),
                          self.workdir / request_name(), self.url)
        entry.serve()
        token = secrets.token_urlsafe(24)
        with self._lock:
            self._entries[token] = entry
            self._expire()
        return token, entry

    def get(self, token: str | None) -> LiveEntry | None:
        """The entry of `token`, None when unknown or expired (using it keeps it alive)."""
        if not isinstance(token, str):
            return None
        with self._lock:
            self._expire()
            entry = self._entries.get(token)
            if entry is not None:
                entry.used = time.monotonic()
                self._entries.move_to_end(token)
        return entry

    def drop(self, token: str | None) -> None:
        """Forget `token` and delete its copy (the page session ended or chose again)."""
        with self._lock:
            entry = self._entries.pop(token, None) if isinstance(token, str) else None
        if entry is not None:
            shutil.rmtree(entry.folder, ignore_errors=True)

    def choose(self, character: Character | None, old: str | None) -> tuple[str | None, dict | None]:
        """The upload's event, after character.py `choose`: (the page session's new token, the live player's spec
        {token, url, key} and `CharacterStream.spec()`'s fields: the player shows the character at rest before the
        first Record); None, None for the mannequin."""
        self.drop(old)
        if character is None:
            return None, None
        token, entry = self._add(character)
        return token, {**CharacterStream(character, self.body).spec(), "token": token, "url": entry.serve(),
                       "key": entry.key}

    def __len__(self) -> int:
        return len(self._entries)

    def _expire(self) -> None:
        now, gone = time.monotonic(), []
        for token, entry in list(self._entries.items()):
            if now - entry.used > self.ttl_s or len(self._entries) > self.max_entries:
                gone.append(self._entries.pop(token))
        for entry in gone:
            shutil.rmtree(entry.folder, ignore_errors=True)


class CharacterStream:
    """One live stream's motion on a character, chunk by chunk (module docstring)."""

    def __init__(self, character: Character, body=None, grounding: bool = True):
        self.character = character
        self.blinker: Blinker | None = None
        self.skeleton = character.skeleton
        self.order = bone_order(self.skeleton)
        self.body = resolve_body(body)
        self.source = SourceBody.of(self.body, None)
        self.channels = face_channels(character)
        self.setup = prepare(self.skeleton, self.source)         # the rest-pose work, once per stream
        self.align, self.scale = self.setup.A, self.setup.scale
        self.ground: Ground | None = None
        self.last: np.ndarray | None = None          # (B, 4) the last frame's quaternions sent
        self.grounder = CharacterStreamGrounder(self.setup) if grounding else None   # its feet on its own legs

    def spec(self) -> dict:
        """What the page's player needs besides the frames (JSON): as character.py `character_payload`'s fields."""
        skel = self.skeleton
        return {"name": self.character.name, "bones": [skel.names[i] for i in self.order],
                "nodes": [skel.nodes[i] for i in self.order], "fps": 30,
                "align": matrix_to_quaternion_xyzw(self.align).tolist(), "scale": float(self.scale),
                "head": self.order.index(skel.bones["head"]) if "head" in skel.bones else 0,
                "morphs": [list(c) for c in self.channels]}

    def chunk(self, seq: MotionSequence) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The next frames of the stream on the character: bone quaternions (T, B, 4) x, y, z, w (hips first, sign
        continuous with the previous chunk), the hips' local translation (T, 3) and the face's morph weights (T, F),
        F = len(spec()["morphs"]) (0 for a character without face presets), float32."""
        r = retarget(seq, self.skeleton, self.source, self.ground, self.setup)
        self.ground = r.ground
        if self.grounder is not None:
            r = self.grounder.push(r)
        q = matrix_to_quaternion_xyzw(r.local_rotation[:, self.order])
        prev = self.last if self.last is not None else q[0]
        q = continuous_quaternions(np.concatenate([prev[None], q]))[1:]     # signs continue the previous chunk's
        if len(q):
            self.last = q[-1].copy()
        if self.blinker is None:
            self.blinker = Blinker(int(seq.fps))                          # one for the stream: blinks cross chunks
        morph = face_morph(self.character, self.channels, seq, self.body, self.blinker) if self.channels else \
            np.zeros((len(q), 0), np.float32)
        return q.astype(np.float32), r.root_translation.astype(np.float32), morph
