"""Reference-free statistics of one generated motion against its own speech, as the page and `gesturelsm sweep`
show them: motion (+ speech) -> named numbers, each with what it measures and which way is better.

    speech = SpeechContext.of(audio, mean_speed=speaker.mean_speed)    # onsets found once per speech
    stats = motion_statistics(motion, stats_body(), speech)           # {"bc": 0.71, "raised_share": 0.42, ...}

Definitions are `gesturelsm eval`'s (evaluation/evaluate.py `motion_stats`) where eval has them: beat
consistency on world joints with the speech's librosa onsets, L1 diversity on joints with the translation
removed, wrist amplitude and upper-body jerk from metrics/amplitude.py, feet and root (foot skate, contact share,
root drift and range, bob, floor penetration, leg jerk) from metrics/feet.py; the two speech-response gains are
metrics/speech_response.py's. Joints come from forward kinematics on the shipped mannequin (what `gesturelsm eval`
uses without `--smplx`), metres, 30 fps, y up. BC normalises joint speeds by the speaker's per-joint mean speed on
the same body (`SpeakerReference.mean_speed`), so motions are compared on one scale.

The speaker's reference row (`speaker_reference()`) is the same statistics of the shipped speaker's training
take, computed once by scripts/speaker_stats.py from ../shared/data/beat2 and stored in assets/speaker_stats.json.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..body import load_body_model
from ..constants import ASSETS, SAMPLE_RATE
from ..metrics.amplitude import RAISED_M, amplitude_stats
from ..metrics.beat import audio_beats, beat_consistency, joint_speed
from ..metrics.diversity import l1_diversity
from ..metrics.feet import CONTACT_M, feet_stats
from ..metrics.speech_response import (beat_timing, beat_timing_frames, energy_following, energy_following_frames,
                                       min_seconds)

SPEAKER_FILE = ASSETS / "speaker_stats.json"
MANNEQUIN = ASSETS / "body" / "SMPLX_MANNEQUIN.npz"


@dataclass(frozen=True)
class Statistic:
    key: str
    label: str             # column heading
    unit: str
    better: str            # which way is better, in words
    what: str              # what it measures, one sentence

    @property
    def tooltip(self) -> str:
        return f"{self.what} Better: {self.better}."


CLOSER = "closer to the speaker's row"
STATISTICS: tuple[Statistic, ...] = (
    Statistic("bc", "beat consistency", "0-1", CLOSER,
              "How close the upper body's pauses in motion fall to the speech's onsets (BC, as gesturelsm eval)."),
    Statistic("beat_gain", "beat timing gain", "BC", "higher (> 0: gestures land on this speech's beats)",
              "BC with the speech's own onsets minus BC with the same onsets shifted in time "
              f"(needs at least {min_seconds(beat_timing_frames()):g} s of speech)."),
    Statistic("loudness_gain", "loudness following", "r", "higher (> 0: moves more when the speech is louder)",
              "Correlation of upper-body speed with speech loudness minus the same with the loudness shifted >= 2 s "
              f"(needs at least {min_seconds(energy_following_frames()):g} s of speech)."),
    Statistic("raised_share", "raised share", "0-1", CLOSER,
              f"Share of frames with a wrist more than {RAISED_M:g} m above the pelvis (hands up, gesturing)."),
    Statistic("height_p95", "wrist height p95", "m", CLOSER,
              "95th percentile over frames of the higher wrist's height above the pelvis (gesture space)."),
    Statistic("wrist_speed", "wrist speed", "m/s", CLOSER, "Mean speed of both wrists relative to the pelvis."),
    Statistic("hand_spread", "hand spread", "m", CLOSER, "Mean distance between the two wrists."),
    Statistic("jerk", "jerk", "m/s^3", "lower, near the speaker's (high: jittery)",
              "Mean jerk (third derivative of position) of the upper-body joints."),
    Statistic("diversity", "L1 diversity", "m", CLOSER,
              "Mean L1 distance of the poses from their own mean pose, 55 joints x 3 axes (Div, as gesturelsm eval)."),
    Statistic("foot_skate", "foot skate", "cm/s", "lower (the speaker's or below)",
              f"Mean horizontal speed of the ankles and feet while within {100 * CONTACT_M:g} cm of the floor (the "
              "floor: 5th percentile of the lowest of them over the take)."),
    Statistic("contact_share", "feet on the floor", "0-1", "higher (standing: above 0.5)",
              f"Share of frames x ankle and foot joints within {100 * CONTACT_M:g} cm of the floor."),
    Statistic("drift_per_min", "root drift", "m/min", "lower (near 0: the body ends where it started)",
              "Horizontal distance between where the body starts and where it ends, per minute of motion."),
    Statistic("root_range", "root range", "m", "lower, within the speaker's",
              "Largest horizontal extent of the pelvis path over the take (the standing area used)."),
    Statistic("bob", "vertical bob", "cm", "lower, near the speaker's", "Standard deviation of the pelvis height."),
    Statistic("penetration", "floor penetration", "cm", "lower (0: never below the floor)",
              "99th percentile over frames of how far the lowest ankle or foot joint is below the floor."),
    Statistic("leg_jerk", "leg jerk", "m/s^3", "lower, near the speaker's (high: jittery legs)",
              "Mean jerk (third derivative of position) of the hips, knees, ankles and feet."),
)
SEED_SPREAD = Statistic("seed_spread", "spread across seeds", "m", "higher (seeds give different motion), "
                        "near the L1 diversity", "Mean L1 distance between the motions of two seeds, frame by frame, "
                        "55 joints x 3 axes, translation removed.")
BY_KEY = {s.key: s for s in (*STATISTICS, SEED_SPREAD)}


@dataclass(frozen=True)
class SpeechContext:
    """What the statistics need of the speech, computed once per speech and shared by every motion."""
    audio: np.ndarray                      # (N,) 16 kHz mono
    beats: np.ndarray                      # onset times (s), librosa, those before 2 s dropped (metrics.beat)
    mean_speed: np.ndarray | None = None   # (55,) m/s per joint for BC; None: each motion's own

    @classmethod
    def of(cls, audio: np.ndarray, mean_speed: np.ndarray | None = None) -> "SpeechContext":
        y = np.asarray(audio, np.float32)
        return cls(y, audio_beats(y), None if mean_speed is None else np.asarray(mean_speed, np.float64))


@lru_cache(maxsize=1)
def stats_body():
    """The body the statistics are measured on: the shipped mannequin (the speaker's row is measured on it too)."""
    return load_body_model(str(MANNEQUIN))


def _gain(test, *args, **kw) -> float:
    try:
        return float(test(*args, **kw).gain)
    except ValueError:                     # speech too short to shift: no baseline
        return float("nan")


def joint_positions(motion, body=None) -> tuple[np.ndarray, np.ndarray]:
    """(world, local) joint positions (T, 55, 3): with the motion's translation and without it. Translation moves
    every joint alike, so local = world - trans (one forward kinematics pass instead of two)."""
    body = body or stats_body()
    world = body.joints(motion.poses, motion.trans)
    return world, world - np.asarray(motion.trans, np.float32)[:, None, :]


def statistics_of_joints(world: np.ndarray, local: np.ndarray, speech: SpeechContext) -> dict[str, float]:
    """STATISTICS of one motion given its joints; NaN where the motion is too short for a statistic."""
    T = len(world)
    out: dict[str, float] = {k: float("nan") for k in BY_KEY if k != "seed_spread"}
    if T >= 4:
        out.update(amplitude_stats(world).as_dict())
    out["bc"] = beat_consistency(world, beats=speech.beats, mean_speed=speech.mean_speed)
    out["beat_gain"] = _gain(beat_timing, world, speech.beats, mean_speed=speech.mean_speed)
    out["loudness_gain"] = _gain(energy_following, world, speech.audio, SAMPLE_RATE)
    out["diversity"] = l1_diversity(local)
    out.update({k: v for k, v in feet_stats(world).as_dict().items() if k in out})
    return {s.key: float(out[s.key]) for s in STATISTICS}


def motion_statistics(motion, body=None, speech: SpeechContext | None = None) -> dict[str, float]:
    """STATISTICS of one MotionSequence against its speech (see the module docstring)."""
    world, local = joint_positions(motion, body)
    return statistics_of_joints(world, local, speech)


def seed_spread(locals_: list[np.ndarray]) -> float:
    """SEED_SPREAD over the motions of several seeds of one setting (joints without translation); NaN for one."""
    if len(locals_) < 2:
        return float("nan")
    n = min(len(j) for j in locals_)
    flat = [np.asarray(j[:n], np.float64).reshape(n, -1) for j in locals_]
    d = [np.abs(a - b).sum(1).mean() for i, a in enumerate(flat) for b in flat[i + 1:]]
    return float(np.mean(d))


@dataclass(frozen=True)
class SpeakerReference:
    """The shipped speaker's own statistics: what the generated motion is compared with."""
    statistics: dict[str, float]
    mean_speed: np.ndarray                 # (55,) m/s per joint on the stats body, for BC
    source: str                            # what it was computed from, said on the page
    seconds: float
    extra: dict = field(default_factory=dict)


def speaker_statistics(motion, audio: np.ndarray, body=None) -> SpeakerReference:
    """The reference row of a speaker's take: STATISTICS of its motion against its own speech, BC normalised by the
    take's own per-joint mean speed (which then normalises every generated motion's BC too)."""
    world, local = joint_positions(motion, body)
    mean_speed = joint_speed(world).mean(0)                                   # (55,)
    stats = statistics_of_joints(world, local, SpeechContext.of(audio, mean_speed))
    return SpeakerReference(stats, mean_speed, "", len(world) / 30)


def save_speaker_reference(ref: SpeakerReference, path: str | Path = SPEAKER_FILE) -> Path:
    path = Path(path)
    path.write_text(json.dumps({"source": ref.source, "seconds": round(ref.seconds, 2), "body": "shipped mannequin",
                                "statistics": {k: round(v, 6) for k, v in ref.statistics.items()},
                                "mean_speed": [round(float(v), 6) for v in ref.mean_speed]}, indent=1) + "\n")
    return path


def speaker_reference(path: str | Path = SPEAKER_FILE) -> SpeakerReference | None:
    """The stored speaker row, or None when the file is missing (the page then shows no reference row)."""
    try:
        d = json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return None
    return SpeakerReference({k: float(v) for k, v in d["statistics"].items()}, np.asarray(d["mean_speed"], np.float64),
                            str(d.get("source", "")), float(d.get("seconds", 0.0)))


ONE_DECIMAL = ("jerk", "foot_skate", "bob", "penetration", "leg_jerk")
TWO_DECIMALS = ("diversity", "seed_spread", "contact_share", "drift_per_min", "root_range")


def format_value(key: str, v: float) -> str:
    if v is None or not np.isfinite(v):
        return "-"
    return f"{v:.1f}" if key in ONE_DECIMAL else f"{v:.2f}" if key in TWO_DECIMALS else f"{v:.3f}"
