"""`gesturelsm body build | check`."""
from __future__ import annotations

import numpy as np

from gesturelsm.body.mannequin import DEFAULT_PATH
from gesturelsm.cli import main


def test_build_writes_the_same_arrays_as_the_shipped_file(tmp_path, capsys):
    out = tmp_path / "m.npz"
    assert main(["body", "build", "--out", str(out)]) == 0
    assert "vertices" in capsys.readouterr().out
    with np.load(out) as a, np.load(DEFAULT_PATH) as b:
        np.testing.assert_allclose(a["v_template"], b["v_template"], atol=1e-6)
        np.testing.assert_array_equal(a["f"], b["f"])


def test_check_prints_the_body_and_reports_bad_files(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("GESTURELSM_SMPLX_MODEL", raising=False)
    assert main(["body", "check"]) == 0
    text = capsys.readouterr().out
    with np.load(DEFAULT_PATH) as d:
        V = len(d["v_template"])
    assert f"vertices:  {V}" in text and "joints:    55" in text and "height:    1.80" in text
    bad = tmp_path / "broken.npz"
    np.savez(bad, v_template=np.zeros((3, 3)))
    assert main(["body", "check", "--model", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "broken.npz is missing 'f'" in err and "SMPLX_NEUTRAL_2020.npz" in err
