"""User-study material: blinded videos of every speech x method, a key kept apart, a randomised order and
a rating sheet per rater (realness, synchrony, smoothness on 1-5 scales, as in GestureLSM's study).

    from gesturelsm.study import make_study
    make_study(pipeline, "speech/", ["gesturelsm", "ddim"], "study/", raters=10)
"""
from .batch import AUDIO_EXTENSIONS, SCALES, StudyPlan, make_study, plan_study

__all__ = ["AUDIO_EXTENSIONS", "SCALES", "StudyPlan", "make_study", "plan_study"]
