"""The work a request needs from its upload alone, done when the upload arrives and reused by the click.

The page calls `GestureService.prefetch` as soon as speech is uploaded or recorded (and again when the transcript,
the TextGrid or the transcription choice change): the file is decoded and the speech prepared exactly as the
request will ask for it (audio features, the transcript typed / from the TextGrid / recognised, word timings and word
features: `GesturePipeline.prepare_speech`). Both are remembered here, the decoded audio by the file (path, size,
modification time) and the prepared speech by the file and the transcript settings, so Generate finds them ready:
its click path neither decodes nor transcribes again. Automatic English words are recognised window by window on a
thread (gesturelsm/pipelined.py): the speech is remembered as soon as its audio features are ready, and a click
while the upload's words are still being recognised joins that recognition (generation starts on the first windows
whose words are final) instead of waiting for all of it. A request that arrives while its upload is still being
prepared waits for that work instead of doing it twice (`memo.Recent`); one whose transcript settings changed
since reuses the decoded audio and prepares the speech for the new settings.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Callable, Hashable

import numpy as np

from ..memo import Recent
from ..pipeline import SpeechInput

KEEP = 16                         # uploads remembered (each a few MB of samples per minute of speech)


def file_key(path: str | os.PathLike | None) -> Hashable | None:
    """What identifies an upload's content cheaply: its path, size and modification time (None: no such file)."""
    if not path:
        return None
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (str(Path(path).resolve()), st.st_size, st.st_mtime_ns)


class PreparedUploads:
    """Decoded uploads and their prepared speech, the newest KEEP of each (thread-safe)."""

    def __init__(self, keep: int = KEEP):
        self.audio: Recent[np.ndarray] = Recent(keep)
        self.speech: Recent[tuple[SpeechInput, list[str]]] = Recent(keep)

    def decoded(self, path: str, decode: Callable[[], np.ndarray]) -> np.ndarray:
        """The upload's 16 kHz samples: remembered, else `decode()` (and remembered)."""
        key = file_key(path)
        return decode() if key is None else self.audio.get(key, decode)

    def prepared(self, path: str, settings: Hashable, prepare: Callable[[], tuple[SpeechInput, list[str]]]
                 ) -> tuple[SpeechInput, list[str]]:
        """(speech, notes) of the upload for these transcript `settings`: remembered, else `prepare()`; speech whose
        words' recognition failed is forgotten and prepared once more (the error is said if it fails again)."""
        key = file_key(path)
        if key is None:
            return prepare()
        got = self.speech.get((key, settings), prepare)
        if got[0].stream is not None and got[0].stream.error is not None:
            self.speech.forget((key, settings))
            got = self.speech.get((key, settings), prepare)
        return got

    def clear(self) -> None:
        self.audio.clear()
        self.speech.clear()
