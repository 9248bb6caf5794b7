"""Evaluation metrics: arrays in, numbers out."""
from .beat import audio_beats, beat_consistency, motion_beats

__all__ = ["audio_beats", "beat_consistency", "motion_beats"]
