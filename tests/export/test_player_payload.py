"""The player's one payload builder (gesturelsm/export/player_payload.py `player_payload` over `Shown`): a slot in each
state gives its entry (made: its motion cut to the shortest made; being made: its motion so far, `partial`; failed: its
error; waiting: nothing), the frames are the speech's while nothing is made, an edit's motion before it is the A/B
`compare`, file names come from the names passed in, and a payload made again writes no file twice."""
from __future__ import annotations

import numpy as np

from gesturelsm.export.player_payload import PlayerFiles, Shown, Slot, player_payload, read_motion, rest_body
from gesturelsm.motion import MotionSequence


def _motion(frames: int, seed: int) -> MotionSequence:
    rng = np.random.default_rng(seed)
    return MotionSequence(poses=rng.normal(0, 0.3, (frames, 165)), trans=rng.normal(0, 0.1, (frames, 3)),
                          expressions=rng.normal(0, 1, (frames, 100)))


def _url(path) -> str:
    return f"file={path}"


def _path(url: str):
    return url.removeprefix("file=")


def _mtimes(folder) -> dict:
    return {p: p.stat().st_mtime_ns for p in folder.rglob("*") if p.is_file()}


def test_every_slot_state_has_its_entry_and_no_file_is_written_twice(body, tmp_path):
    out, cache, wav = tmp_path / "req-1", tmp_path / "bodies", tmp_path / "speech.wav"
    wav.write_bytes(b"RIFF")
    a, b, partial, before = _motion(40, 1), _motion(36, 2), _motion(12, 3), _motion(40, 4)
    shown = Shown((Slot("a", "A", a), Slot("p", "P", partial=partial), Slot("f", "F", error="it failed"),
                   Slot("w", "W"), Slot("b", "B, edited", b, partial=partial, error="ignored")),
                  seconds=1.5, before=("b", before))
    p = player_payload(shown, body, out, cache, _url, audio=wav)

    assert (p["fps"], p["frames"], p["duration"], p["joints"]) == (30, 36, 36 / 30, 55)    # the shortest made
    assert (p["audio"], p["id"]) == (_url(wav), "req-1")
    rest = _url(rest_body(body, cache))
    made, grow, failed, waiting, edited = p["bodies"]
    assert [x["method"] for x in p["bodies"]] == ["a", "p", "f", "w", "b"]
    assert set(made) == {"label", "method", "body", "motion", "expressions"} and made["label"] == "A"
    assert made["motion"] == _url(out / "player-0-a.bin") and edited["motion"] == _url(out / "player-4-b.bin")
    assert "partial" not in edited and "error" not in edited and edited["label"] == "B, edited"   # made wins
    assert grow["partial"] is True and grow["frames"] == 12 and grow["motion"] == _url(out / "player-1-p-upto-12.bin")
    assert failed == {"label": "F", "method": "f", "body": rest, "motion": None, "expressions": 0,
                      "error": "it failed"}
    assert waiting == {"label": "W", "method": "w", "body": rest, "motion": None, "expressions": 0}
    assert p["compare"] == {"index": 4, "method": "b", "motion": _url(out / "player-4-b-before.bin")}
    rec = {k: read_motion(_path(x["motion"])) for k, x in [("a", made), ("p", grow), ("b", edited)]}
    assert (rec["a"].frames, rec["p"].frames, rec["b"].frames) == (36, 12, 36)          # made: cut; partial: whole
    assert rec["a"].expressions.shape[1] == made["expressions"] == grow["expressions"]
    assert read_motion(_path(p["compare"]["motion"])).frames == 36                      # cut as the made ones

    written = _mtimes(tmp_path)
    again = player_payload(shown, body, out, cache, _url, audio=wav)
    assert again == p and _mtimes(tmp_path) == written                                  # nothing written again


def test_with_nothing_made_the_frames_are_the_speechs_and_names_are_passed_in(body, tmp_path):
    files = PlayerFiles(made=lambda i, m: f"m{i}{m}.bin", partial=lambda i, m, n: f"p{i}{m}{n}.bin",
                        before=lambda i, m: f"b{i}{m}.bin")
    shown = Shown((Slot("a", "A"), Slot("p", "P", partial=_motion(9, 5))), seconds=2.0)
    p = player_payload(shown, body, tmp_path / "out", tmp_path / "bodies", _url, files=files)
    assert (p["fps"], p["frames"], p["duration"], p["audio"]) == (30, 60, 2.0, None)
    assert p["bodies"][0]["motion"] is None and "compare" not in p
    assert p["bodies"][1]["motion"] == _url(tmp_path / "out" / "p1p9.bin")
    made = Shown((Slot("a", "A", _motion(20, 6)),), seconds=2.0, before=("a", _motion(30, 7)))
    q = player_payload(made, body, tmp_path / "out", tmp_path / "bodies", _url, files=files)
    assert q["frames"] == 20 and q["bodies"][0]["motion"] == _url(tmp_path / "out" / "m0a.bin")
    assert q["compare"]["motion"] == _url(tmp_path / "out" / "b0a.bin")
    assert sorted(f.name for f in (tmp_path / "out").iterdir()) == ["b0a.bin", "m0a.bin", "p1p9.bin"]
