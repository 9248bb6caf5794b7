import json

import numpy as np
import pytest

from gesturelsm.cli import main
from gesturelsm.evaluation import EvalPlanItem, heldout_clips
from gesturelsm.evaluation.evaluate import evaluate


def test_heldout_policy_without_split_file(tiny_beat2):
    clips, policy = heldout_clips(tiny_beat2)
    assert [c.motion is not None for c in clips] == [True, False]
    held = clips[0]
    assert held.motion.num_frames == 60 and held.duration == pytest.approx(2.0)   # last 20% of 300 frames
    assert clips[1].duration == pytest.approx(6.0)
    assert "last 20%" in policy and "audio-only" in policy


class OraclePipeline:
    """Returns the ground truth of whichever clip it is asked for: every distance to GT must be 0."""

    def __init__(self, clips):
        self.by_len = {len(c.audio): c for c in clips}

    def prepare_speech(self, audio, sr, words=None):
        return len(audio)

    def generate(self, speech, steps, cfg, seed, method, output="finished"):
        from types import SimpleNamespace

        assert output == "raw"                          # eval measures the motion as the method made it

        c = self.by_len[speech]
        motion = c.motion if c.motion is not None else _still(len(c.audio))
        return SimpleNamespace(motion=motion, generation_seconds=0.5)


def _still(n_samples):
    from gesturelsm.motion import MotionSequence

    T = n_samples * 30 // 16000
    return MotionSequence(np.zeros((T, 165)), np.tile([0, 1.0, 0], (T, 1)), np.zeros((T, 100)))


def test_evaluating_ground_truth_against_itself(tiny_beat2):
    clips, _ = heldout_clips(tiny_beat2, train_fraction=0.5)      # 150 held-out frames: several FGD windows
    rep = evaluate(OraclePipeline(clips), clips, [EvalPlanItem("oracle", 1, 1.0)], seeds=2)
    row, gt = rep["rows"][0], rep["ground_truth"]
    h = row["heldout"]
    assert h["fgd_k"] == pytest.approx(0.0, abs=1e-9) and h["fgd_g"] == pytest.approx(0.0, abs=1e-9)
    assert gt["bc"] is not None and h["bc"] == pytest.approx(gt["bc"])
    assert gt["diversity"] > 0 and h["diversity"] == pytest.approx(gt["diversity"])
    assert h["expr_mse"] == 0.0
    for k in ("raised_share", "height_p95", "wrist_speed", "hand_spread"):       # wrist amplitude
        assert gt[k] is not None and h[k] == pytest.approx(gt[k])
    assert row["audio_only"]["wrist_speed"] == 0.0 and gt["hand_spread"] > 0
    assert row["audio_only"]["diversity"] == 0.0                   # the still pose of the audio-only take
    assert row["seconds_per_clip"] == 0.5


def test_eval_cli_on_tiny_checkpoints(eval_assets, tiny_beat2, tmp_path):
    """Also the face-vertex path: `--smplx` given the built-in mannequin file (no real SMPL-X here)."""
    from gesturelsm.body import resolve_model_path

    out = tmp_path / "ev"
    rc = main(["eval", "--data", str(tiny_beat2), "--checkpoints", str(eval_assets), "--steps", "1", "2",
               "--seeds", "1", "--train-fraction", "0.5", "--smplx", str(resolve_model_path(None)), "--out", str(out)])
    assert rc == 0
    rep = json.loads((out / "eval.json").read_text())
    assert {(r["method"], r["steps"]) for r in rep["rows"]} == {(m, s) for m in ("ddim", "gesturelsm", "rectified_flow")
                                                                  for s in (1, 2)}
    for r in rep["rows"]:
        assert r["heldout"]["fgd_k"] > 0 and 0 <= r["heldout"]["bc"] <= 1 and r["audio_only"]["diversity"] > 0
        assert r["heldout"]["vertex_mse"] > 0
    md = (out / "eval.md").read_text()
    assert "face vertex MSE" in md and "| ground truth |" in md
    assert "| GestureLSM | 1 | 2 |" in md and "Audio-only takes" in md
    assert "Wrist amplitude" in md and "| GestureLSM | 2 | 2 | " in md
    assert "4.988" in md                                            # the paper's 2-step FGD beside ours
    # feet and root (metrics/feet.py) for ground truth and every row, the ground truth's from its own joints
    from gesturelsm.metrics.feet import FeetStats

    assert "Feet and root" in md and "| ground truth | - | - | held-out |" in md
    for part in [rep["ground_truth"]] + [r["heldout"] for r in rep["rows"]] + [r["audio_only"] for r in rep["rows"]]:
        assert set(FeetStats.__dataclass_fields__) <= set(part) and part["contact_share"] is not None


def test_eval_cli_rejects_bad_settings(eval_assets, tiny_beat2, tmp_path, capsys):
    assert main(["eval", "--data", str(tiny_beat2), "--checkpoints", str(eval_assets), "--steps", "0",
                 "--out", str(tmp_path)]) == 2
    assert "steps" in capsys.readouterr().err


def test_eval_reports_the_genea_columns_and_ground_truth_against_itself_scores_zero(tiny_beat2):
    from gesturelsm.evaluation.tables import eval_markdown

    clips, _ = heldout_clips(tiny_beat2, train_fraction=0.5)
    rep = evaluate(OraclePipeline(clips), clips, [EvalPlanItem("oracle", 1, 1.0)], seeds=2)
    h = rep["rows"][0]["heldout"]
    # not exactly 0: two seeds pool the clips twice and the reference's unbiased covariance scales by N - 1
    assert h["fid_g"] == pytest.approx(0.0, abs=1e-3) and h["fid_k"] == pytest.approx(0.0, abs=1e-3)
    assert h["var_k"] > 0 and h["sample_div"] == pytest.approx(0.0, abs=1e-12)   # the oracle: the same each seed
    assert "GENEA Leaderboard pose columns" in eval_markdown(rep)
