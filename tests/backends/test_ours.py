"""Golden motions of the shipped models: 3 s of synthetic speech, seed 0, CFG 2, audio only, at 1 and 8 steps.
Any change to how our backends prepare, sample, stitch or decode shows up here (values recorded from this
code on one thread; the tolerance admits float summation-order differences of other thread counts and CPU kernels,
~1e-5 relative, far below what another seed, step count or method changes)."""
from __future__ import annotations

import numpy as np
import pytest
import torch

from _support import speech_like
from gesturelsm.pipeline import GesturePipeline

# (method, steps) -> (sum |poses|, sum poses) of the (90, 165) axis-angle poses
GOLDEN = {
    ("gesturelsm", 1): (2708.30322265625, 90.12847900390625),
    ("gesturelsm", 8): (2791.4052734375, 148.12574768066406),
    ("rectified_flow", 1): (2488.62548828125, 62.687835693359375),
    ("rectified_flow", 8): (2777.886962890625, 145.00970458984375),
    ("ddim", 1): (2444.5224609375, -32.334014892578125),
    ("ddim", 8): (2549.94677734375, -67.00936889648438),
}


pytestmark = pytest.mark.slow                        # the shipped network, six generations


@pytest.fixture(scope="module")
def shipped() -> GesturePipeline:
    threads = torch.get_num_threads()
    torch.set_num_threads(1)                 # the summation order the values were recorded with
    yield GesturePipeline.from_pretrained(warm_up=False)
    torch.set_num_threads(threads)


@pytest.mark.parametrize("method, steps", list(GOLDEN))
def test_shipped_motion_matches_its_golden_values(shipped, method, steps):
    m = shipped.generate(speech_like(3.0), 16000, steps=steps, cfg=2.0, seed=0, method=method, transcribe=False,
                         output="raw").motion
    assert m.num_frames == 90
    abs_sum, total = GOLDEN[method, steps]
    assert float(np.abs(m.poses).sum()) == pytest.approx(abs_sum, rel=1e-5)
    assert float(m.poses.sum()) == pytest.approx(total, abs=2e-2)
