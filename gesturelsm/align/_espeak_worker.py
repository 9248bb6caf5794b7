"""Run as a script (no package imports): speak a text with eSpeak NG in several voices, report word events.

stdin: one JSON object {"text": str, "voices": [str], "rate": int}. stdout: one JSON line
{"sr": int, "voices": [{"voice", "events": [[text_position, sample]], "samples": int} or {"voice", "error"}]}
followed by the int16 little-endian samples of each voice, in order.

eSpeak keeps state between calls inside one process (the same text comes out slightly different the second
time), so the aligner starts this worker afresh for each transcript: results are then reproducible.
"""
import ctypes
import ctypes.util
import json
import sys

LIB_NAMES = ("libespeak-ng.so.1", "libespeak-ng.so", "libespeak-ng.1.dylib", "libespeak-ng.dylib", "espeak-ng")
EVENT_WORD, OUT_SYNCHRONOUS, INIT_DONT_EXIT, RATE, WORDGAP, CHARS_UTF8 = 1, 2, 0x8000, 1, 7, 1


class EventId(ctypes.Union):
    _fields_ = [("number", ctypes.c_int), ("name", ctypes.c_char_p), ("string", ctypes.c_char * 8)]


class Event(ctypes.Structure):  # espeak_EVENT in speak_lib.h
    _fields_ = [("type", ctypes.c_int), ("unique_identifier", ctypes.c_uint), ("text_position", ctypes.c_int),
                ("length", ctypes.c_int), ("audio_position", ctypes.c_int), ("sample", ctypes.c_int),
                ("user_data", ctypes.c_void_p), ("id", EventId)]


CALLBACK = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.POINTER(ctypes.c_short), ctypes.c_int, ctypes.POINTER(Event))


def load_library():
    for name in (*LIB_NAMES, ctypes.util.find_library("espeak-ng")):
        if name:
            try:
                return ctypes.CDLL(name)
            except OSError:
                continue
    return None


def main() -> int:
    request = json.loads(sys.stdin.read())
    lib = load_library()
    if lib is None:
        print(json.dumps({"error": "eSpeak NG is not installed (Debian/Ubuntu: apt-get install espeak-ng; "
                                   "macOS: brew install espeak-ng)"}))
        return 0
    lib.espeak_Synth.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_uint, ctypes.c_int, ctypes.c_uint,
                                 ctypes.c_uint, ctypes.POINTER(ctypes.c_uint), ctypes.c_void_p]
    lib.espeak_SetVoiceByName.argtypes = [ctypes.c_char_p]
    sr = lib.espeak_Initialize(OUT_SYNCHRONOUS, 0, None, INIT_DONT_EXIT)
    if sr <= 0:
        print(json.dumps({"error": "eSpeak NG is installed but its data (espeak-ng-data) was not found"}))
        return 0
    chunks, events = [], []

    def on_audio(wav, n, ev):
        if wav and n > 0:
            chunks.append(ctypes.string_at(wav, 2 * n))
        k = 0
        while ev[k].type != 0:
            if ev[k].type == EVENT_WORD:
                events.append([ev[k].text_position, ev[k].sample])
            k += 1
        return 0

    callback = CALLBACK(on_audio)
    lib.espeak_SetSynthCallback(callback)
    data = request["text"].encode("utf-8") + b"\0"
    report, audio = [], []
    for voice in request["voices"]:
        if lib.espeak_SetVoiceByName(voice.encode()) != 0:
            report.append({"voice": voice, "error": f"eSpeak NG has no voice {voice!r} (see: espeak-ng --voices)"})
            continue
        lib.espeak_SetParameter(RATE, int(request["rate"]), 0)
        lib.espeak_SetParameter(WORDGAP, 0, 0)
        chunks.clear()
        events.clear()
        lib.espeak_Synth(data, len(data), 0, 1, 0, CHARS_UTF8, None, None)
        lib.espeak_Synchronize()
        pcm = b"".join(chunks)
        report.append({"voice": voice, "events": list(events), "samples": len(pcm) // 2})
        audio.append(pcm)
    out = sys.stdout.buffer
    out.write(json.dumps({"sr": sr, "voices": report}).encode() + b"\n")
    for pcm in audio:
        out.write(pcm)
    out.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
