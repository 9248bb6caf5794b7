"""What an audio file really is, and how long it is, before anything decodes it.

Uploads are hostile until proven otherwise: the file name says nothing (a playlist can be called
`speech.wav`), and a 2 MB FLAC can hold 10 hours of silence. So:

- `sniff_container` reads the first bytes and names the container from its magic number (an allow-list:
  WAV/RF64, FLAC, Ogg, MP3, AAC (ADTS), MP4/M4A, WebM/Matroska, AIFF, CAF, WMA/ASF,
  AMR). Anything else (playlists such as
  .m3u8, text, HTML, images, ...) is `None` and must not be handed to a decoder.
- `probe_duration` reads the duration from the container header (libsndfile's header parse, or the
  bundled ffmpeg's demuxer without decoding) so a too-long file is refused before any sample is decoded.
  It is a hint, never trusted alone: headers can lie or be absent, so decoding is bounded as well (see
  `loading.load_audio`).
- `ffmpeg_input_args` pins ffmpeg to the sniffed demuxer and to the local-file protocol, so ffmpeg never
  opens another file or URL named inside the upload (HLS/concat playlists, MP4 data references).
"""
from __future__ import annotations

import re
import subprocess
from dataclasses import dataclass
from pathlib import Path

SNIFF_BYTES = 64
PROBE_TIMEOUT_S = 20.0


@dataclass(frozen=True)
class Container:
    name: str                  # what the page calls it: "WAV", "FLAC", ...
    demuxer: str               # ffmpeg's -f name for exactly this container
    soundfile: bool            # libsndfile reads it (header-parsed duration, block-wise reads)


WAV = Container("WAV", "wav", True)
FLAC = Container("FLAC", "flac", True)
OGG = Container("Ogg", "ogg", True)
MP3 = Container("MP3", "mp3", True)
AAC = Container("AAC", "aac", False)
MP4 = Container("MP4/M4A", "mov", False)
WEBM = Container("WebM/Matroska", "matroska", False)
AIFF = Container("AIFF", "aiff", True)
CAF = Container("CAF", "caf", True)
ASF = Container("WMA/ASF", "asf", False)
AMR = Container("AMR", "amr", False)
ALLOWED = (WAV, FLAC, OGG, MP3, AAC, MP4, WEBM, AIFF, CAF, ASF, AMR)


def _id3_size(head: bytes) -> int:
    """Length of an ID3v2 tag at the start of `head` (header + syncsafe size), 0 when there is none."""
    if len(head) < 10 or head[:3] != b"ID3" or any(b & 0x80 for b in head[6:10]):
        return 0
    size = (head[6] << 21) | (head[7] << 14) | (head[8] << 7) | head[9]
    return 10 + size + (10 if head[5] & 0x10 else 0)          # footer flag


def _mpeg_audio_frame(h: bytes) -> bool:
    """A plausible MPEG-1/2/2.5 layer I-III frame header (11 sync bits, valid layer/bitrate/rate)."""
    if len(h) < 4 or h[0] != 0xFF or (h[1] & 0xE0) != 0xE0:
        return False
    version, layer = (h[1] >> 3) & 3, (h[1] >> 1) & 3
    bitrate, rate = h[2] >> 4, (h[2] >> 2) & 3
    return version != 1 and layer != 0 and bitrate != 15 and rate != 3


def _adts_frame(h: bytes) -> bool:
    """An AAC ADTS frame header (12 sync bits, layer 00, valid sampling index)."""
    return len(h) >= 7 and h[0] == 0xFF and (h[1] & 0xF6) == 0xF0 and ((h[2] >> 2) & 0xF) < 13


def sniff_bytes(head: bytes) -> Container | None:
    """The container whose magic number `head` (the file's first bytes) starts with, or None."""
    if len(head) >= 12 and head[:4] in (b"RIFF", b"RF64", b"BW64") and head[8:12] == b"WAVE":
        return WAV
    if head[:4] == b"fLaC":
        return FLAC
    if head[:4] == b"OggS":
        return OGG
    if len(head) >= 12 and head[4:8] == b"ftyp":
        return MP4
    if head[:4] == b"\x1a\x45\xdf\xa3":
        return WEBM
    if len(head) >= 12 and head[:4] == b"FORM" and head[8:12] in (b"AIFF", b"AIFC"):
        return AIFF
    if head[:4] == b"caff":
        return CAF
    if head[:8] == b"\x30\x26\xb2\x75\x8e\x66\xcf\x11":
        return ASF
    if head[:5] == b"#!AMR":
        return AMR
    if _adts_frame(head):
        return AAC
    if _mpeg_audio_frame(head):
        return MP3
    return None


def sniff_container(path: str | Path) -> Container | None:
    """The container of the file at `path` by content (not by name); an ID3 tag in front of MP3, FLAC or
    AAC data is skipped. None for anything not on the allow-list."""
    with open(path, "rb") as f:
        head = f.read(SNIFF_BYTES)
        skip = _id3_size(head)
        if not skip:
            return sniff_bytes(head)
        f.seek(skip)
        inner = sniff_bytes(f.read(SNIFF_BYTES))
    return inner if inner in (MP3, FLAC, AAC) else None


def ffmpeg_input_args(path: str | Path, container: Container) -> list[str]:
    """ffmpeg options that open `path` as exactly `container`, from the local file only: no format
    probing (which would pick the HLS or concat demuxer for a playlist), no other protocols."""
    return ["-protocol_whitelist", "file", "-f", container.demuxer, "-i", str(path)]


_DURATION = re.compile(r"Duration:\s*(\d+):(\d\d):(\d\d(?:\.\d+)?)")


def probe_duration(path: str | Path, container: Container) -> float | None:
    """Seconds of audio as the container header states them, without decoding; None when the header
    does not say (streamed FLAC/WebM, for example) or cannot be parsed."""
    if container.soundfile:
        import soundfile as sf

        try:
            info = sf.info(str(path))
        except Exception:  # libsndfile cannot parse it: ffmpeg may (its reader is the fallback too)
            info = None
        if info is not None:
            if 0 < info.frames < 2 ** 62 and info.samplerate > 0:
                return info.frames / info.samplerate
            return None
    return _ffmpeg_duration(path, container)


def _ffmpeg_duration(path: str | Path, container: Container) -> float | None:
    import imageio_ffmpeg

    cmd = [imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-nostdin", *ffmpeg_input_args(path, container)]
    try:  # no output file: ffmpeg reads the header, prints the input's description and stops
        proc = subprocess.run(cmd, capture_output=True, timeout=PROBE_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        return None
    m = _DURATION.search(proc.stderr[-65536:].decode(errors="replace"))
    if not m:
        return None
    h, mnt, s = m.groups()
    return int(h) * 3600 + int(mnt) * 60 + float(s)


def describe_seconds(seconds: float) -> str:
    """A length for messages: '12.5 s' below two minutes, else '5 minutes' / '600.0 minutes'."""
    if seconds < 120:
        return f"{seconds:.1f} s"
    minutes = seconds / 60
    return f"{minutes:g} minutes" if minutes == int(minutes) else f"{minutes:.1f} minutes"


__all__ = ["AAC", "AIFF", "ALLOWED", "AMR", "ASF", "CAF", "FLAC", "MP3", "MP4", "OGG", "WAV", "WEBM", "Container",
           "describe_seconds", "ffmpeg_input_args", "probe_duration", "sniff_bytes", "sniff_container"]
