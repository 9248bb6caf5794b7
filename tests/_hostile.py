"""Hostile upload files for the hardening tests, made in milliseconds without an encoder (hostile character files:
`_hostile_characters.py`).

`silent_flac(path, seconds)` writes a valid FLAC stream of digital silence: every frame is one CONSTANT
subframe (a 16-bit zero) of 65,535 samples, so 10 hours at 16 kHz are ~8,800 frames of 11 bytes (~100 KB),
which libsndfile and ffmpeg decode to 576 million samples. `stated_samples=0` writes the "unknown length"
header that streaming encoders leave, so the duration is only found by decoding.
"""
from __future__ import annotations

from pathlib import Path

BLOCK = 65535


def _crc8(data: bytes) -> int:                        # FLAC frame header CRC: poly x^8+x^2+x+1
    crc = 0
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = ((crc << 1) ^ 0x07) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    return crc


def _crc16(data: bytes) -> int:                       # FLAC frame footer CRC: poly x^16+x^15+x^2+1
    crc = 0
    for b in data:
        crc ^= b << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x8005) & 0xFFFF if crc & 0x8000 else (crc << 1) & 0xFFFF
    return crc


def _utf8_number(n: int) -> bytes:
    """FLAC's UTF-8-like coding of the frame number (up to 31 bits)."""
    if n < 0x80:
        return bytes([n])
    for length, lead in ((2, 0xC0), (3, 0xE0), (4, 0xF0), (5, 0xF8), (6, 0xFC)):
        if n < 1 << (5 * length + 1):
            out = [0x80 | ((n >> (6 * k)) & 0x3F) for k in range(length - 1)][::-1]
            return bytes([lead | (n >> (6 * (length - 1)))] + out)
    raise ValueError(n)


def silent_flac(path: Path, seconds: float, sr: int = 16000, stated_samples: int | None = None) -> Path:
    """A mono 16-bit FLAC of `seconds` of silence; the header states `stated_samples` (default: the truth)."""
    total = int(seconds * sr)
    stated = total if stated_samples is None else stated_samples
    info = bytearray()
    info += BLOCK.to_bytes(2, "big") * 2                         # min / max block size
    info += (0).to_bytes(3, "big") * 2                           # min / max frame size unknown
    packed = (sr << 44) | (0 << 41) | (15 << 36) | stated        # rate 20 b, channels-1 3 b, bps-1 5 b, total 36 b
    info += packed.to_bytes(8, "big") + bytes(16)                # MD5 unknown
    out = bytearray(b"fLaC" + bytes([0x80]) + len(info).to_bytes(3, "big") + info)   # last metadata block
    frames, done, k = [], 0, 0
    while done < total:
        n = min(BLOCK, total - done)
        head = b"\xff\xf8\x70\x08" + _utf8_number(k) + (n - 1).to_bytes(2, "big")   # 16-bit block size at end
        head += bytes([_crc8(head)])
        frame = head + b"\x00\x00\x00"                           # CONSTANT subframe, value 0 (16 bits)
        frames.append(frame + _crc16(frame).to_bytes(2, "big"))
        done, k = done + n, k + 1
    out += b"".join(frames)
    path.write_bytes(bytes(out))
    return path


def playlist_naming(path: Path, target: Path) -> Path:
    """An HLS playlist (.m3u8) whose only segment is a file on the server."""
    path.write_text(f"#EXTM3U\n#EXT-X-TARGETDURATION:600\n#EXTINF:600,\nfile://{target}\n#EXT-X-ENDLIST\n")
    return path

