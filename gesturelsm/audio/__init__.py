"""Speech input, below everything that uses it: what a file really is and how long it claims to be, before
anything decodes it (`containers.py`: sniffing by content on an allow-list, the header's duration, ffmpeg's input
options), and reading it as float32 mono at 16 kHz (`loading.py`). Errors are `errors.AudioError`."""
from ..constants import SAMPLE_RATE
from ..errors import AudioError
from .containers import Container, describe_seconds, probe_duration, sniff_container
from .loading import MAX_CHANNELS, MAX_SAMPLE_RATE, AudioTooLongError, load_audio, resample, to_mono

__all__ = ["SAMPLE_RATE", "AudioError", "AudioTooLongError", "Container", "MAX_CHANNELS", "MAX_SAMPLE_RATE",
           "describe_seconds", "load_audio", "probe_duration", "resample", "sniff_container", "to_mono"]
