"""The real take's source body and SMPL-X joints, for whichever slice of it (`take`) a test module retargets."""
from __future__ import annotations

import numpy as np
import pytest

from gesturelsm.retarget import SourceBody


@pytest.fixture(scope="module")
def source(take, body):
    return SourceBody.of(body, take.betas)


@pytest.fixture(scope="module")
def smplx_joints(take, body):
    """SMPL-X's posed joints from the body model's own forward pass (not the retargeting's kinematics)."""
    return body.forward(take.poses, take.trans, betas=take.betas).joints[:, :55].astype(np.float64)
