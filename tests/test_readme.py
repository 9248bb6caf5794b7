"""The README is a front door: short, every page it links exists, the commands it names exist, and its Python
example runs as written."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
README = (REPO / "README.md").read_text()


def test_readme_is_a_page_and_its_links_resolve():
    assert len(README.splitlines()) <= 200
    links = re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", README)
    assert {"docs/WEBAPP.md", "docs/LIVE.md", "docs/CLI.md", "assets/MODEL_CARD.md"} <= set(links)
    assert [link for link in links if not (REPO / link).exists()] == []
    for page in (REPO / "docs").glob("*.md"):           # links between the docs pages too
        for link in re.findall(r"\]\(([^)#:]+)(?:#[^)]*)?\)", page.read_text()):
            assert (page.parent / link).exists(), f"{page.name} links to {link}, which does not exist"


def test_readme_commands_exist():
    make = (REPO / "Makefile").read_text()
    for target in ("demo", "test", "test-fast"):
        assert re.search(rf"(?m)^{re.escape(target)}:", make) and f"make {target}" in README


@pytest.mark.slow
def test_readme_python_example_runs(tmp_path, monkeypatch):
    import soundfile as sf

    from gesturelsm.constants import ASSETS

    from _support import speech_like

    if not (ASSETS / "generator" / "gesturelsm.safetensors").exists():
        pytest.skip("shipped checkpoints not found in assets/")
    code = re.search(r"```python\n(.*?)```", README, re.S).group(1)
    sf.write(tmp_path / "speech.wav", speech_like(2.0, seed=1), 16000)
    monkeypatch.chdir(tmp_path)
    scope: dict = {}
    exec(compile(code, "README.md", "exec"), scope)            # the README's own example
    res = scope["res"]
    assert res.motion.num_frames == 60 and np.isfinite(res.motion.poses).all()
