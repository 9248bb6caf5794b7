"""Code, comments and docstrings say what the code does and why, not its history: no release numbers, issue numbers,
dates, commit hashes, or files outside the repository (history belongs in CHANGELOG.md, measurements in the
benchmarks' output and docs/BENCHMARKS.md). The one commit-like name allowed is the version of the authors' code that
gesturelsm/reference reproduces (docs/AUTHORS-CODE.md)."""
from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
FOLDERS = ("gesturelsm", "app", "tests", "benchmarks", "scripts")
SUFFIXES = {".py", ".js", ".mjs", ".css", ".sh", ".html"}
SKIP_PARTS = {"node_modules", "dist", "__pycache__", "fixtures"}
UPSTREAM_VERSION = "fe124e0"          # the authors' code that gesturelsm/reference reproduces

PATTERNS = {
    "a release number": re.compile(r"\breleases?[- ]\d", re.I),
    "an issue number": re.compile(r"\bissues? #?\d+", re.I),
    "a date": re.compile(r"\b20\d\d-[01]\d-[0-3]\d\b"),
    "a commit hash": re.compile(r"(?<![\w#/.-])(?=[0-9a-f]*[a-f])(?=[0-9a-f]*\d)[0-9a-f]{7,40}(?![\w-])"),
    "a file outside the repository": re.compile("METHOD" + r"-FACTS"),
}


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
                    if m.group(0) != UPSTREAM_VERSION:
                        found.append(f"{path.relative_to(REPO)}:{n}: {name}: {line.strip()[:100]}")
    assert found == []
