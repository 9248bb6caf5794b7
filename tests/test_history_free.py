"""Code, comments and docstrings say what the code does and why, not its history: no release numbers, issue numbers,
dates, commit hashes, or files outside the repository (history belongs in CHANGELOG.md, measurements in the
benchmarks' output and docs/BENCHMARKS.md). The one commit-like name allowed is the version of the authors' code that
gesturelsm/reference reproduces (docs/AUTHORS-CODE.md). Docstrings do not compare the code with an earlier version
of itself either ("now", "no longer", "previously", "used to", "than before", "after this change"): a sentence that
uses such a word about time itself (the moment something runs, a state that has ended) is listed in ABOUT_TIME."""
from __future__ import annotations

import ast
import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
FOLDERS = ("gesturelsm", "app", "tests", "benchmarks", "scripts")
SUFFIXES = {".py", ".js", ".mjs", ".css", ".sh", ".html"}
SKIP_PARTS = {"node_modules", "dist", "__pycache__", "fixtures"}
UPSTREAM_VERSION = "fe124e0"          # the authors' code that gesturelsm/reference reproduces
GENEA_RULES = "2025-11-17"            # the GENEA Leaderboard rules' version, a name the submission checks carry

PATTERNS = {
    "a release number": re.compile(r"\breleases?[- ]\d", re.I),
    "an issue number": re.compile(r"\bissues? #?\d+", re.I),
    "a date": re.compile(r"\b20\d\d-[01]\d-[0-3]\d\b"),
    "a commit hash": re.compile(r"(?<![\w#/.-])(?=[0-9a-f]*[a-f])(?=[0-9a-f]*\d)[0-9a-f]{7,40}(?![\w-])"),
    "a file outside the repository": re.compile("METHOD" + r"-FACTS"),
}


HISTORY = re.compile(r"\b(now|no longer|previously|used to|formerly|any ?more|until recently|(than|as) (before|earlier)"
                     r"|(before|after) (this|that|the) (change|fix|rewrite|refactor|release|version))\b", re.I)
# file -> pieces of the docstring sentences that use a word of HISTORY about time itself, not about the code's past
ABOUT_TIME: dict[str, tuple[str, ...]] = {
    "gesturelsm/kernels/ops.py": ("may take a fast path now",),
    "gesturelsm/live/session.py": ("Stop now",),
    "gesturelsm/live/stream.py": ("motion chunks available now", "now)"),
    "gesturelsm/pipeline.py": ("compile librosa's onset kernels now", "Transcribe now what"),
    "gesturelsm/render/background.py": ("what the process now has",),
    "gesturelsm/study/db.py": ("holds the study now", "on the rater's screen now", "made just now"),
    "gesturelsm/study/server.py": ("cannot take an answer just now",),
    "gesturelsm/study/store.py": ("another one than before",),
    "gesturelsm/study/design.py": ("their trial lists are fixed now",),
    "benchmarks/transcribe_accuracy.py": ("resident now",),
}


def _sentences(text: str) -> list[str]:
    return [" ".join(s.split()) for s in re.split(r"(?<=[.;:!?])\s+|\n\s*\n", text)]


def history_in_docstrings(path: Path) -> list[tuple[int, str]]:
    """(line, sentence) for every docstring sentence of `path` with a word of HISTORY."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            doc = ast.get_docstring(node, clean=False)
            line = node.body[0].lineno if node.body else 0
            found += [(line, sentence) for sentence in _sentences(doc or "") if HISTORY.search(sentence)]
    return found


def _files() -> list[Path]:
    return sorted(p for folder in FOLDERS for p in (REPO / folder).rglob("*")
                  if p.suffix in SUFFIXES and p.is_file() and not SKIP_PARTS & set(p.parts)
                  and p != Path(__file__).resolve())


def test_the_patterns_catch_what_they_are_for():
    samples = {"a release number": "the release 5 decoders", "an issue number": "(issue 16)",
               "a date": "measured 2026-11-25", "a commit hash": "at commit 61304c2",
               "a file outside the repository": "see " + "METHOD" + "-FACTS.md"}
    assert {name: bool(PATTERNS[name].search(text)) for name, text in samples.items()} == dict.fromkeys(samples, True)
    assert not PATTERNS["a commit hash"].search("seed 1234567, color #a0b1c2d, value 0x7fffffff, width 1280")


def test_no_history_or_outside_files_in_the_tree():
    assert len(_files()) > 100
    found = []
    for path in _files():
        for n, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
            for name, pat in PATTERNS.items():
                for m in pat.finditer(line):
                    if m.group(0) not in (UPSTREAM_VERSION, GENEA_RULES):
                        found.append(f"{path.relative_to(REPO)}:{n}: {name}: {line.strip()[:100]}")
    assert found == []


def test_the_history_words_are_caught_in_docstrings_and_time_itself_is_not(tmp_path):
    code = tmp_path / "m.py"
    code.write_text('"""Reads the file. It now uses the cache; the old reader no longer runs."""\n\n\n'
                    'def f():\n    """Was slower than before; after this change it is checked before any work."""\n\n\n'
                    'def g():\n    """Refused before it is decoded, after the first frame."""\n')
    assert [s for _, s in history_in_docstrings(code)] == [
        "It now uses the cache;", "the old reader no longer runs.", "Was slower than before;",
        "after this change it is checked before any work."]


def test_no_docstring_narrates_the_codes_history():
    found, used = [], set()
    for path in (p for p in _files() if p.suffix == ".py"):
        rel = path.relative_to(REPO).as_posix()
        for line, sentence in history_in_docstrings(path):
            pieces = {piece for piece in ABOUT_TIME.get(rel, ()) if piece in sentence}
            used |= {(rel, piece) for piece in pieces}
            if not pieces:
                found.append(f"{rel}:{line}: {sentence[:120]}")
    assert found == []
    assert used == {(f, piece) for f, pieces in ABOUT_TIME.items() for piece in pieces}, "an allowance not needed"
