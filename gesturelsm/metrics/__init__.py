"""Evaluation metrics: arrays in, numbers out.

| metric | module | unit / convention |
|---|---|---|
| beat consistency (BC) | beat.py | 0..1; compare with ground truth's BC |
| Frechet distance, FGD extractors | frechet.py, fgd.py, motion_features.py, emage_fgd.py | see each |
| L1 diversity | diversity.py | metres, summed over 55 joints x 3 axes |
| face error | face.py | expression MSE; vertex MSE m^2 |
| jitter | physics.py | m/s^3 |
| feet and root: foot skate, contact share, root drift and range, bob, floor penetration, leg jerk | feet.py | cm/s,
0..1, m, cm, m/s^3 |
| speech response: beat timing, loudness following | speech_response.py | gain over time-shifted speech, z |
"""
from .beat import audio_beats, beat_consistency, motion_beats
from .diversity import l1_diversity
from .face import expression_mse, face_vertex_mse
from .fgd import EmageExtractor, GeometricExtractor, KineticExtractor, default_extractors, fgd
from .frechet import frechet_distance, gaussian_stats
from .feet import FeetStats, feet_stats
from .physics import jitter
from .speech_response import ShiftTest, beat_timing, energy_following

__all__ = ["audio_beats", "beat_consistency", "motion_beats", "l1_diversity", "expression_mse", "face_vertex_mse",
           "EmageExtractor", "GeometricExtractor", "KineticExtractor", "default_extractors", "fgd",
           "frechet_distance", "gaussian_stats", "FeetStats", "feet_stats", "jitter", "ShiftTest", "beat_timing",
           "energy_following"]
