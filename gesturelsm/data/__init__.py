"""Datasets: the BEAT2 folder reader and windowing."""
from .beat2 import Beat2Dataset, DatasetError, Take, Window, iter_windows, match_length
from .training_windows import window_starts

__all__ = ["Beat2Dataset", "DatasetError", "Take", "Window", "iter_windows", "match_length", "window_starts"]
