"""`gesturelsm study results` on studies answered with known choices: exact win counts, ties, the attention rule
and its flags, the reference method; a rating study answered through the server's HTTP API gives the means the
raters gave."""
from __future__ import annotations


import pytest

from _study_support import answer_all, csv_rows, make_synthetic_study

ORDER = ["alpha", "beta", "gamma"]


def _choose(rid, t, genuine):
    if t.check == "mismatch":                       # rater 4 picks the mismatched speech
        return t.expect if rid != 4 else {"left": "right", "right": "left"}[t.expect]
    a, b = genuine[t.left], genuine[t.right]
    if rid == 2 and {a, b} == {"beta", "gamma"}:
        return "none"
    if rid == 4:                                     # and prefers the reverse order
        return "left" if ORDER.index(a) > ORDER.index(b) else "right"
    return "left" if ORDER.index(a) < ORDER.index(b) else "right"


@pytest.fixture(scope="module")
def pairwise(tmp_path_factory):
    folder = make_synthetic_study(tmp_path_factory.mktemp("res") / "study", methods=ORDER, raters=4,
                                  attention=0.4)
    answer_all(folder, _choose)
    return folder


def test_pairwise_results_count_exactly_and_drop_the_inattentive_rater(pairwise, capsys):
    from gesturelsm.cli import main

    assert main(["study", "results", str(pairwise), "--bootstrap", "200"]) == 0
    printed = capsys.readouterr().out
    assert "Raters kept: 3 of 4; rater 4 dropped (mismatch 0/2)" in printed
    pairs = {(r["method_a"], r["method_b"]): r for r in csv_rows(pairwise / "results" / "pairwise.csv")}
    ab, bc, ac = pairs["alpha", "beta"], pairs["beta", "gamma"], pairs["alpha", "gamma"]
    # 3 kept raters x 2 speeches per pair; rater 2 has no preference between beta and gamma
    assert (ab["a_wins"], ab["b_wins"], ab["ties"], ab["raters"], ab["trials"]) == ("6", "0", "0", "3", "6")
    assert (bc["a_wins"], bc["b_wins"], bc["ties"], bc["trials"]) == ("4", "0", "2", "6")
    assert float(ac["a_win_rate"]) == 1.0 and float(ac["ci_low"]) == pytest.approx(0.6097, abs=1e-3)  # Wilson 6/6
    assert float(ab["p"]) == pytest.approx(2 / 64) and float(ab["p_holm"]) == pytest.approx(min(1, 3 * 2 / 64))
    scores = csv_rows(pairwise / "results" / "scores.csv")
    assert [s["method"] for s in sorted(scores, key=lambda s: -float(s["score"]))] == ORDER
    assert float(next(s for s in scores if s["method"] == "alpha")["score"]) == 0       # the reference
    md = (pairwise / "results" / "results.md").read_text()
    assert "Ranking: alpha > beta > gamma" in md and (pairwise / "results" / "results.png").exists()


def test_flags_change_the_rule_and_the_reference(pairwise, capsys):
    from gesturelsm.cli import main

    assert main(["study", "results", str(pairwise), "--keep-all", "--reference", "beta", "--bootstrap", "100",
                 "--out", str(pairwise / "all")]) == 0
    assert "Raters kept: 4 of 4" in capsys.readouterr().out
    ab = next(r for r in csv_rows(pairwise / "all" / "pairwise.csv") if r["method_b"] == "beta")
    assert (ab["a_wins"], ab["b_wins"]) == ("6", "2")
    assert float(next(s for s in csv_rows(pairwise / "all" / "scores.csv") if s["method"] == "beta")["score"]) == 0
    assert main(["study", "results", str(pairwise), "--reference", "delta"]) == 2
    assert "--reference 'delta'" in capsys.readouterr().err
    assert main(["study", "results", str(pairwise), "--mismatch-pass", "2"]) == 2
    assert main(["study", "results", str(pairwise), "--db", "nope://x"]) == 2
    assert "not a database URL" in capsys.readouterr().err
    assert main(["study", "serve", str(pairwise.parent)]) == 2
    assert "not a study folder" in capsys.readouterr().err


def test_rating_study_through_the_server_gives_the_raters_means(tmp_path):
    from starlette.testclient import TestClient

    from gesturelsm.cli import main
    from gesturelsm.study.design import read_conditions, read_raters
    from gesturelsm.study.server import Study, build_app

    folder = make_synthetic_study(tmp_path / "study", methods=("alpha", "beta"), raters=2, mode="rating",
                                  attention=0.5)
    genuine = {v: m for v, (_, m) in read_conditions(folder).genuine.items()}
    given = {"alpha": dict(realness=5, synchrony=4, smoothness=4), "beta": dict(realness=2, synchrony=2,
                                                                                  smoothness=3)}
    c = TestClient(build_app(Study.open(folder)))
    for rater in read_raters(folder).values():
        st = c.post(f"/api/{rater.token}/open").json()
        assert st["trial"]["kind"] == "rating" and [s["name"] for s in st["trial"]["scales"]] == \
            ["realness", "synchrony", "smoothness"]
        bad = c.post(f"/api/{rater.token}/answer", json=dict(session=st["session"], trial=0, ratings=dict(realness=6)))
        assert bad.status_code == 400 and "1 to 5" in bad.json()["error"]
        for t in rater.trials:
            r = dict(realness=3, synchrony=1, smoothness=3) if t.check == "mismatch" else given[
                genuine[rater.trials[t.of].left if t.check == "repeat" else t.left]]
            assert c.post(f"/api/{rater.token}/answer", json=dict(session=st["session"], trial=t.index, ratings=r,
                                                                 played=True)).status_code == 200
    assert main(["study", "results", str(folder), "--bootstrap", "100"]) == 0
    means = {(r["scale"], r["method"]): r for r in csv_rows(folder / "results" / "ratings.csv")}
    for m, scales in given.items():
        for s, v in scales.items():
            row = means[s, m]
            assert float(row["mean"]) == v and float(row["ci_low"]) == v and row["raters"] == "2"
            assert row["trials"] == "4"                             # 2 raters x 2 speeches
    assert "Raters kept: 2 of 2" in (folder / "results" / "results.md").read_text()


def test_results_with_no_answers_says_so_and_creates_no_database(tmp_path, capsys):
    from gesturelsm.cli import main
    from gesturelsm.study import db

    folder = make_synthetic_study(tmp_path / "study", raters=2)
    for extra in ([], ["--keep-all"]):
        assert main(["study", "results", str(folder), *extra]) == 1
        out = capsys.readouterr()
        assert "no answers yet" in out.out and "attention" not in out.out + out.err
        assert not list(folder.glob("responses.sqlite*")) and not (folder / "results").exists()
    # a database the server made, nobody answered yet; closed as the server closes it at exit (an engine left to the
    # garbage collector keeps its connection and WAL open, and a reader then sees the WAL's valid first page)
    db.open_db(db.default_url(folder)).dispose()
    assert main(["study", "results", str(folder)]) == 1
    assert "no answers yet" in capsys.readouterr().out
    (folder / "responses.sqlite").write_bytes(b"not a database" * 100)
    assert main(["study", "results", str(folder)]) == 2
    assert "cannot read the answers database" in capsys.readouterr().err
