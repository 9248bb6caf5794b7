"""Elo beside Bradley-Terry, no ranking where the data cannot support one, and `study invite`'s links."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from _study_support import answer_all, csv_rows, make_synthetic_study
from gesturelsm.cli import main


def test_elo_is_bradley_terry_rescaled_around_1000():
    from gesturelsm.study import stats

    s = np.array([0.0, 0.5, -1.2])
    e = stats.elo(s)
    assert e.mean() == pytest.approx(1000)
    assert e[1] - e[0] == pytest.approx(0.5 * 400 / math.log(10))
    # a 200-point gap is preferred about 76 % of the time, as Bradley-Terry says for the same gap
    gap = 200 / (400 / math.log(10))
    assert 1 / (1 + math.exp(-gap)) == pytest.approx(0.76, abs=0.005)


def test_pairwise_results_report_elo_consistent_with_bradley_terry(tmp_path, capsys):
    order = ["alpha", "beta", "gamma"]
    folder = make_synthetic_study(tmp_path / "study", methods=order, raters=6, speeches=3, attention=0.0)
    rng = np.random.default_rng(1)
    strength = {"alpha": 1.0, "beta": 0.4, "gamma": 0.0}

    def choose(rid, t, genuine):
        a, b = genuine[t.left], genuine[t.right]
        return "left" if rng.random() < 1 / (1 + math.exp(strength[b] - strength[a])) else "right"

    answer_all(folder, choose)
    assert main(["study", "results", str(folder), "--keep-all", "--bootstrap", "300"]) == 0
    out = capsys.readouterr().out
    assert "Elo" in out
    scores = {r["method"]: r for r in csv_rows(folder / "results" / "scores.csv")}
    bt = np.array([float(scores[m]["score"]) for m in order])
    elo = np.array([float(scores[m]["elo"]) for m in order])
    assert elo.mean() == pytest.approx(1000, abs=1)
    assert elo - elo.mean() == pytest.approx(400 / math.log(10) * (bt - bt.mean()), abs=1.0)
    for m in order:                                       # the same bootstrap: the same order of the bounds
        r = scores[m]
        assert float(r["elo_low"]) <= float(r["elo"]) <= float(r["elo_high"])
        assert float(r["ci_low"]) <= float(r["score"]) <= float(r["ci_high"])
    assert list(np.argsort(-elo)) == list(np.argsort(-bt))


def test_one_rater_and_one_comparison_give_no_ranking(tmp_path, capsys):
    folder = make_synthetic_study(tmp_path / "study", methods=("ddim", "gesturelsm"), speeches=1, raters=1,
                                  attention=0.0)
    answer_all(folder, lambda rid, t, genuine: "left" if genuine[t.left] == "ddim" else "right")
    assert main(["study", "results", str(folder), "--keep-all", "--bootstrap", "50"]) == 0
    out = capsys.readouterr().out
    assert "Ranking: ddim > gesturelsm" not in out
    assert "Ranking: none, the data cannot support one: 1 rater kept" in out and "at least 2" in out
    assert "n/a (1 rater)" in out and "[+2.40, +2.40]" not in out
    pair = csv_rows(folder / "results" / "pairwise.csv")[0]
    assert (pair["raters"], pair["trials"]) == ("1", "1")
    summary = json.loads((folder / "results" / "summary.json").read_text())
    assert summary["ranking"] == [] and "1 rater kept" in summary["no_ranking"]


def test_invite_prints_links_and_writes_full_urls_when_given_the_address(tmp_path, capsys):
    folder = make_synthetic_study(tmp_path / "study", methods=("a", "b"), speeches=2, raters=1)
    assert main(["study", "invite", str(folder), "2"]) == 0
    out = capsys.readouterr().out
    assert out.count("/r/") == 2 and "give --base-url" in out
    assert main(["study", "invite", str(folder), "1", "--base-url", "https://study.example.org/"]) == 0
    out = capsys.readouterr().out
    assert "rater 4: https://study.example.org/r/" in out
    rows = csv_rows(folder / "key" / "links.csv")
    assert len(rows) == 4 and all(r["url"] == "https://study.example.org" + r["link"] for r in rows)
    assert main(["study", "invite", str(folder), "1"]) == 0          # the address is remembered
    assert "rater 5: https://study.example.org/r/" in capsys.readouterr().out
    assert csv_rows(folder / "key" / "links.csv")[-1]["url"].startswith("https://study.example.org/r/")


def test_invite_refuses_a_bad_address_and_has_help(tmp_path, capsys):
    folder = make_synthetic_study(tmp_path / "study", methods=("a", "b"), speeches=2, raters=1)
    assert main(["study", "invite", str(folder), "1", "--base-url", "study.example.org"]) == 2
    assert "--base-url" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["study", "invite", "--help"])
    text = capsys.readouterr().out
    assert "unguessable" in text and "--base-url" in text and "how many raters" in text
