"""Edits with the authors' methods (reduced-size converted checkpoints): the registry says which can hold known
latents; their GestureLSM edits the regions it generates, keeping the rest bit for bit; the others refuse."""
from __future__ import annotations

import numpy as np
import pytest

from gesturelsm.motion.editing import EditError
from gesturelsm.motion.merge import joint_angles
from gesturelsm.motion.regions import REGIONS
from _support import speech_like


def _joints(motion, region):
    return motion.poses.reshape(motion.num_frames, 55, 3)[:, list(REGIONS[region].joints)]


def test_the_registry_says_which_methods_can_edit_and_the_others_refuse(ckpt_dir):
    from gesturelsm.backends import SPECS
    from gesturelsm.pipeline import GesturePipeline

    assert {k for k, s in SPECS.items() if s.inpainting} == {"gesturelsm", "rectified_flow", "ddim",
                                                             "gesturelsm_authors", "diffusion_authors"}
    pipe = GesturePipeline.from_pretrained(checkpoints=[ckpt_dir], warm_up=False)
    speech = pipe.prepare_speech(speech_like(6.0), 16000, transcribe=False)
    motion = pipe.generate(speech, steps=2, method="gesturelsm_authors", output="raw").motion
    with pytest.raises(EditError, match="meanflow_authors cannot edit a motion: its sampler cannot hold known latents; "
                                        "methods that can: gesturelsm_authors"):
        pipe.edit(motion, speech, {"upper": [(1.0, 2.0)]}, method="meanflow_authors")
    with pytest.raises(EditError, match="gesturelsm_authors does not generate the face region"):
        pipe.edit(motion, speech, {"face": [(1.0, 2.0)]}, method="gesturelsm_authors")
    out = pipe.edit(motion, speech, {"upper": [(2.0, 4.0)], "lower": [(2.0, 4.0)]}, method="gesturelsm_authors",
                    steps=2, seed=5).motion
    assert np.array_equal(_joints(out, "hands"), _joints(motion, "hands"))
    assert np.array_equal(out.expressions, motion.expressions)
    assert np.array_equal(_joints(out, "upper")[:60], _joints(motion, "upper")[:60])
    assert np.array_equal(out.trans[120:], motion.trans[120:])
    assert np.degrees(joint_angles(_joints(out, "upper")[60:120], _joints(motion, "upper")[60:120])).mean() > 2
