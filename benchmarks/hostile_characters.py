"""Hostile character files through the real entry points: the answer each gets and the peak memory it costs.

    PYTHONPATH=.:tests .venv/bin/python benchmarks/hostile_characters.py [--only NAME ...] [--entry export render page]
                                                                        [--quick] [--jobs 2]

The files are tests/_hostile_characters.py's (the tests check the same answers): truncated and mislabelled GLBs,
accessors asking for 100,000,000 vertices, decompression-bomb textures, JSON nested 100,000 deep, malformed nodes,
NaN translations, cycles, absurd BVH hierarchies ... plus two controls, the generator's valid VRM and the real
../shared/assets/characters/cryptovoxels.vrm (the normal run). Each file goes through, each in a fresh process:

* export: `gesturelsm export m.npz --rig FILE --glb out.vrm` (`--bvh out.bvh` for a BVH);
* render: `gesturelsm render m.npz --rig FILE --out out.mp4 --size 256` (a 1 s video of the mannequin's standing
          motion with moving arms, tests/_standing.py, so that its feet are planted on the character's legs);
* page:   the Character upload's handler (`webapp.character.choose`), then what a Generate does with the character:
          the player's payload, the downloads (`rig_downloads`) and the video in its render process (`render_apart`,
          as the app service runs it, here not niced), for two methods.

Peak memory is the process tree's high-water mark (`os.wait4`'s ru_maxrss: the process and the render process it
waited for). Linux carries a parent's high-water mark into its children, so this process imports neither gesturelsm
nor torch: a child process builds the files and the motion. A row fails when an answer is a traceback, differs from
what the generator says the file must get, or when its peak is more than 1 GB above the same entry point's control
(cryptovoxels.vrm, else the valid VRM).
`--quick` leaves out the slow files (1,000,000 vertices drawn, eight 8k textures, 40 and 65 MB files).
"""
from __future__ import annotations

from _harness import CHARACTERS

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tests"))

from _hostile_characters import Crafted, character_cases  # noqa: E402  (declarations: no gesturelsm, no torch)

VRM = CHARACTERS / "cryptovoxels.vrm"
ENTRIES = ("export", "render", "page")
OVER_CONTROL_MB = 1024
TIMEOUT_S = 900

BUILD = r"""
import json, sys
from pathlib import Path
from _hostile_characters import character_cases, write_characters
from _standing import standing

folder, motion, original, quick, names = sys.argv[1:6]
cases = [c for c in character_cases(Path(original), slow=quick == "0") if c.name in json.loads(names)]
write_characters(cases, Path(folder))
standing(seconds=1.0).save(motion)
"""

PAGE = r"""
import json, sys, warnings
from pathlib import Path
from gesturelsm.errors import GestureError
from gesturelsm.motion import MotionSequence
from gesturelsm.render.background import render_apart
from gesturelsm.render.frames import RenderWarning
from gesturelsm.webapp.character import character_payload, choose, rig_downloads

path, motion, folder = sys.argv[1], sys.argv[2], Path(sys.argv[3])
with warnings.catch_warnings(record=True) as caught:                 # gr.Warning outside an event: a UserWarning
    warnings.simplefilter("always")
    character, _ = choose(path)
said = [str(w.message) for w in caught if issubclass(w.category, UserWarning)]
if character is None:
    print(json.dumps({"refused": said[0] if said else "(refused without a word)"}))
    sys.exit(0)
seq = MotionSequence.load(motion)
motions = {"gesturelsm": seq, "ddim": seq}
try:
    character_payload(character, motions)
    rig_downloads(character, motions, folder)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", RenderWarning)
        render_apart(list(motions.values()), None, folder / "video.mp4", labels=list(motions), size=(256, 256),
                     rig=character.path, nice=0)
except GestureError as exc:                                        # the page shows it on Generate: not at upload
    print(json.dumps({"generate": str(exc)}))
    sys.exit(0)
notes = [str(w.message) for w in caught if issubclass(w.category, RenderWarning)]
print(json.dumps({"ok": len(character.skeleton.bones), "notes": notes}))
"""


def run(cmd: list[str], cwd: Path, timeout: float = TIMEOUT_S) -> dict:
    """Run `cmd`: exit status, stdout, stderr, seconds and the peak resident memory (MB) of its process tree."""
    env = dict(os.environ, PYTHONPATH=f"{REPO}{os.pathsep}{REPO / 'tests'}", GRADIO_ANALYTICS_ENABLED="False",
               HF_HUB_DISABLE_TELEMETRY="1", OMP_NUM_THREADS="1")
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        t0 = time.perf_counter()
        proc = subprocess.Popen(cmd, stdout=out, stderr=err, cwd=cwd, env=env)
        timer = threading.Timer(timeout, proc.kill)
        timer.start()
        _, status, usage = os.wait4(proc.pid, 0)
        timer.cancel()
        proc.returncode = os.waitstatus_to_exitcode(status)
        seconds = time.perf_counter() - t0
        out.seek(0)
        err.seek(0)
        return {"rc": proc.returncode, "stdout": out.read().decode(errors="replace"),
                "stderr": err.read().decode(errors="replace"), "seconds": seconds,
                "peak_mb": usage.ru_maxrss / 1024}


def _cli_answer(r: dict) -> tuple[str, str]:
    """(kind, text): kind 'ok' | 'refused' | 'traceback' | 'crash'; text the one line (or the notes)."""
    err = r["stderr"]
    if "Traceback" in err:
        return "traceback", err.strip().splitlines()[-1]
    if r["rc"] == 0:
        notes = [ln[6:] for ln in err.splitlines() if ln.startswith("note: ") and "silent" not in ln]
        return "ok", "; ".join(notes)
    lines = [ln for ln in err.strip().splitlines() if ln.strip() and not ln.startswith("note: ")]
    if r["rc"] == 2 and len(lines) == 1:
        return "refused", re.sub(r"^gesturelsm \w+: error: ", "", lines[0])
    return "crash", f"exit {r['rc']}: " + (lines[-1] if lines else "(nothing said)")


def _page_answer(r: dict) -> tuple[str, str]:
    if "Traceback" in r["stderr"] or r["rc"] != 0:
        lines = r["stderr"].strip().splitlines()
        return ("traceback" if "Traceback" in r["stderr"] else "crash"), lines[-1] if lines else f"exit {r['rc']}"
    said = json.loads(r["stdout"].strip().splitlines()[-1])
    if "refused" in said:
        return "refused", said["refused"]
    if "generate" in said:
        return "generate", said["generate"]
    return "ok", "; ".join(said["notes"])


def run_entry(case: Crafted | None, path: Path, entry: str, work: Path, motion: Path) -> dict:
    """One file through one entry point: {kind, text, peak_mb, seconds}."""
    folder = Path(tempfile.mkdtemp(dir=work))
    py = [sys.executable, "-m", "gesturelsm"]
    if entry == "page" and path.suffix.lower() not in (".vrm", ".glb", ".gltf"):
        return {"kind": "n/a", "text": "", "peak_mb": float("nan"), "seconds": 0.0}
    if entry == "export":
        out = ["--bvh", str(folder / "out.bvh")] if path.suffix.lower() == ".bvh" else ["--glb", str(folder / "o.vrm")]
        r = run(py + ["export", str(motion), "--rig", str(path), *out], folder)
        kind, text = _cli_answer(r)
    elif entry == "render":
        r = run(py + ["render", str(motion), "--rig", str(path), "--out", str(folder / "o.mp4"), "--size", "256",
                      "--quiet"], folder)
        kind, text = _cli_answer(r)
    else:
        r = run([sys.executable, "-c", PAGE, str(path), str(motion), str(folder)], folder)
        kind, text = _page_answer(r)
    return {"kind": kind, "text": text, "peak_mb": r["peak_mb"], "seconds": r["seconds"]}


def expected(case: Crafted | None, entry: str) -> tuple[str, str | None]:
    """(kind, pattern) the generator says `entry` must answer for `case` (None: a control, usable)."""
    if case is None:
        return "ok", None
    if case.refused:
        return "refused", case.refused
    if entry != "export" and case.drawn:
        return "refused", case.drawn
    if entry == "page" and case.upload:
        return "refused", case.upload
    return "ok", case.note if entry != "export" else None


def judge(case: Crafted | None, entry: str, got: dict) -> str:
    """'' when the answer is the expected one, else why not."""
    if got["kind"] == "n/a":
        return ""
    kind, pattern = expected(case, entry)
    if got["kind"] != kind:
        return f"expected {kind}, got {got['kind']}"
    if pattern and not re.search(pattern, got["text"]):
        return f"expected /{pattern}/"
    return ""


def _short(kind: str, text: str, name: str) -> str:
    """An answer for the table: the one line without the file's name, 'OK', 'OK, note: ...'."""
    text = text.replace(f"{name}: ", "").replace("|", "/")
    if kind == "ok":
        return "OK" + (f", note: {text}" if text else "")
    if kind == "n/a":
        return "(not a page type)"
    return text if kind == "refused" else f"**{kind.upper()}**: {text}"


def table(rows: list[tuple], entries: tuple[str, ...]) -> list[str]:
    head = "| file | what | " + " | ".join(f"{e}: answer | {e}: peak MB" for e in entries) + " | s |"
    out = [head, "|" + "---|" * (2 + 2 * len(entries) + 1)]
    for name, what, results, _ in rows:
        cells = []
        for e in entries:
            g = results[e]
            cells += [_short(g["kind"], g["text"], name), "" if g["kind"] == "n/a" else f"{g['peak_mb']:.0f}"]
        seconds = sum(results[e]["seconds"] for e in entries)
        out.append(f"| {name} | {what} | " + " | ".join(cells) + f" | {seconds:.1f} |")
    return out


def summary(rows: list[tuple], entries: tuple[str, ...]) -> tuple[list[str], int]:
    """Lines after the table and the number of failed rows (wrong answers, tracebacks, peaks over the control)."""
    lines, failed = [], 0
    controls = {name: results for name, _, results, case in rows if case is None or name == "valid.vrm"}
    control = controls.get(VRM.name) or controls.get("valid.vrm")
    for e in entries:
        peaks = [(results[e]["peak_mb"], name) for name, _, results, _ in rows if results[e]["kind"] != "n/a"]
        top = max(peaks)
        base = control[e]["peak_mb"] if control else float("nan")
        lines.append(f"- {e}: control {base:.0f} MB; highest {top[0]:.0f} MB ({top[1]}), {top[0] - base:+.0f} MB over "
                     "the control")
    for name, _, results, case in rows:
        for e in entries:
            why = judge(case, e, results[e])
            over = control is not None and results[e]["peak_mb"] - control[e]["peak_mb"] > OVER_CONTROL_MB
            if why or over:
                failed += 1
                lines.append(f"- FAILED {name} / {e}: {why or 'peak more than 1 GB over the control'}")
    tracebacks = sum(r[2][e]["kind"] == "traceback" for r in rows for e in entries)
    lines.append(f"- {len(rows)} files, {len(entries)} entry points: {tracebacks} tracebacks, {failed} failed answers")
    return lines, failed


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--only", nargs="+", metavar="NAME", help="only these files (substrings of their names)")
    p.add_argument("--entry", nargs="+", choices=ENTRIES, default=list(ENTRIES))
    p.add_argument("--quick", action="store_true", help="leave out the slow files")
    p.add_argument("--jobs", type=int, default=1, help="files run at once (peaks are per process either way)")
    args = p.parse_args(argv)
    entries = tuple(e for e in ENTRIES if e in args.entry)
    cases = character_cases(VRM if VRM.exists() else None, slow=not args.quick)
    if args.only:
        cases = [c for c in cases if c.name == "valid.vrm" or any(o in c.name for o in args.only)]
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        motion = work / "m.npz"
        built = run([sys.executable, "-c", BUILD, str(work / "files"), str(motion), str(VRM), str(int(args.quick)),
                     json.dumps([c.name for c in cases])], work)
        if built["rc"]:
            raise SystemExit(f"building the files failed:\n{built['stderr']}")
        paths = {c.name: work / "files" / c.name for c in cases}
        todo = ([(None, VRM.name, "the real cryptovoxels.vrm (the control)", VRM)] if VRM.exists() else []) + \
            [(c, c.name, c.what, paths[c.name]) for c in cases]

        def one(item) -> tuple:
            case, name, what, path = item
            results = {e: run_entry(case, path, e, work, motion) for e in entries}
            said = ", ".join(f"{e} {results[e]['kind']} {results[e]['peak_mb']:.0f} MB {results[e]['seconds']:.0f} s"
                             for e in entries)
            print(f"{name}: {said}", file=sys.stderr, flush=True)
            return name, what, results, case

        with ThreadPoolExecutor(max(1, args.jobs)) as pool:
            rows = list(pool.map(one, todo))
    lines, failed = summary(rows, entries)
    print("\n".join(table(rows, entries) + [""] + lines))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
