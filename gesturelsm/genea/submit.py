"""`gesturelsm genea submit`: every speech file's K samples, one speech a unit of work (here, or a task on a Ray
cluster with --cluster, as `batch` spreads its videos), checked as the leaderboard would check them before a file
is written (submission.py)."""
from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from ..align.textgrid import read_words
from ..audio import load_audio
from ..cluster import Connection, Files, Job, ProgressLine, Unit, run_units, write_atomic
from ..constants import SAMPLE_RATE
from ..export import npz_bytes
from ..pipeline import GesturePipeline
from ..settings import Settings
from .submission import Manifest, check_name, check_speech, refuse_all, sample_name, sample_seeds, sha256

AUDIO_EXTENSIONS = (".wav", ".flac", ".mp3", ".ogg", ".m4a", ".webm", ".opus", ".aac")


@dataclass(frozen=True)
class SubmitSpec:
    checkpoints: tuple[Files, ...]
    method: str
    max_seconds: float


@dataclass(frozen=True)
class SpeechUnit:
    stem: str
    audio: np.ndarray = field(repr=False)       # 16 kHz mono
    words: tuple | None
    settings: Settings
    seeds: tuple[int, ...]


def build(spec: SubmitSpec) -> GesturePipeline:
    return GesturePipeline.from_pretrained(checkpoints=[f.local() for f in spec.checkpoints] or None,
                                           methods=[spec.method], max_seconds=spec.max_seconds)


def make_samples(pipe: GesturePipeline, unit: SpeechUnit) -> dict[str, bytes]:
    """The speech's samples (file name -> npz bytes), one per seed, the speech prepared once."""
    try:
        speech = pipe.prepare_speech(unit.audio, SAMPLE_RATE, words=list(unit.words) if unit.words else None,
                                     transcribe=unit.settings.transcribe, language=unit.settings.language)
    except ValueError as exc:                  # InputError: too short, silent, too long
        raise type(exc)(f"{unit.stem}: {exc}") from None
    out = {}
    for k, seed in enumerate(unit.seeds, 1):
        made = pipe.generate(speech, settings=replace(unit.settings, seed=seed))          # finished motion
        out[sample_name(unit.stem, k)] = npz_bytes(made.motion)
    return out


def find_speech(speech_dir: Path) -> list[Path]:
    files = sorted(p for p in Path(speech_dir).iterdir() if p.is_file() and p.suffix.lower() in AUDIO_EXTENSIONS)
    if not files:
        refuse_all([f"{speech_dir} has no speech files ({', '.join(AUDIO_EXTENSIONS)})"])
    return files


def plan_units(files: list[Path], textgrids: Path | None, settings: Settings, samples: int,
               max_seconds: float) -> list[Unit]:
    """A unit per speech file; every name and transcript checked before any audio is generated."""
    problems = [p for f in files if (p := check_name(f.stem))]
    if len({f.stem for f in files}) != len(files):
        problems.append("two speech files share a name (stem); the leaderboard would not tell them apart")
    grids = {}
    for f in files:
        if textgrids is not None:
            g = textgrids / f"{f.stem}.TextGrid"
            if not g.is_file():
                problems.append(f"--textgrids {textgrids}: no {g.name} for {f.name}")
            grids[f.stem] = g
    refuse_all(problems)
    seeds = tuple(sample_seeds(settings.seed, samples))
    units = []
    for f in files:
        words = tuple(read_words(grids[f.stem])) if f.stem in grids else None
        audio = load_audio(f, max_seconds=max_seconds)
        units.append(Unit(f.stem, SpeechUnit(f.stem, audio, words, settings, seeds), cost=len(audio) / SAMPLE_RATE,
                          label=f.name))
    return units


def submit(speech_dir: Path, out: Path, settings: Settings, *, samples: int, checkpoints: list[Path],
           textgrids: Path | None = None, max_seconds: float, connection: Connection | None = None,
           pipeline: GesturePipeline | None = None, log=print) -> Manifest:
    """Write OUT/<stem>_sample<k>.npz for every speech file and OUT/manifest.json; a speech whose files fail the
    leaderboard's checks is refused (nothing of it written), every other one is written."""
    from .submission import checkpoint_hashes

    method = settings.generators[0]
    files = find_speech(speech_dir)
    units = plan_units(files, textgrids, settings, samples, max_seconds)
    out.mkdir(parents=True, exist_ok=True)
    ship = connection is not None
    spec = SubmitSpec(tuple(Files.of(c, ship) for c in checkpoints), method, max_seconds)
    manifest = Manifest(dict(method=method, steps=settings.steps_for(method), cfg=settings.cfg, seed=settings.seed,
                             samples=samples, post=asdict(settings.post), transcribe=settings.transcribe,
                             language=settings.language,
                             transcript="TextGrid" if textgrids else
                             ("recognised" if settings.transcribe else "none (audio only)")),
                        checkpoint_hashes(checkpoints, method), {})
    speech_hash = {f.stem: sha256(f) for f in files}
    refused: list[str] = []
    bar = ProgressLine()

    def write(unit: Unit, made: dict[str, bytes]) -> None:
        s: SpeechUnit = unit.inputs
        problems = check_speech(s.stem, made, len(s.audio) / SAMPLE_RATE)
        if problems:
            refused.extend(problems)
            return
        for k, (name, data) in enumerate(sorted(made.items()), 1):
            write_atomic(out / name, data)
            manifest.files[name] = dict(speech=unit.label, speech_sha256=speech_hash[s.stem], sample=k,
                                        seed=s.seeds[k - 1])
        bar.write(f"  {unit.label}: {len(made)} samples")

    if connection is not None:
        log(f"{len(units)} speech file(s) to make on the {connection.describe()}")
    report = run_units(Job(make_samples, build, spec), units, write, connection=connection,
                       built=pipeline if connection is None else None, progress=bar, noun="speech files")
    manifest.write(out)
    refuse_all(refused)
    report.raise_failures("speech files")
    log(f"{len(manifest.files)} files for {len(manifest.files) // max(samples, 1)} speech file(s) in {out}; "
        f"manifest {out / 'manifest.json'}")
    return manifest


__all__ = ["SpeechUnit", "SubmitSpec", "build", "find_speech", "make_samples", "plan_units", "submit"]
