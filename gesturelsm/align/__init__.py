"""Word timings for speech without Montreal Forced Aligner: TextGrid I/O and transcript alignment.

    from gesturelsm.align import align_words, read_result, words_per_frame
    result = align_words(audio_16k, "Hello there, I'm 21.")   # AlignmentResult(words, confidence, method, warning)
    result = read_result("upload.TextGrid")                    # method "textgrid"
    per_frame = words_per_frame(result.words, num_frames, fps=30)

Times are seconds from the first audio sample; audio is (N,) float32 mono at 16 kHz.
"""
from .aligner import AlignConfig, align_words
from .textgrid import TextGridError, read_result, read_textgrid, read_words, write_textgrid
from .words import AlignmentResult, Word, words_per_frame

__all__ = ["AlignConfig", "AlignmentResult", "TextGridError", "Word", "align_words", "read_result", "read_textgrid",
           "read_words", "words_per_frame", "write_textgrid"]
