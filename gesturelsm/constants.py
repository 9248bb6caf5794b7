"""Conventions shared by the whole package, defined once: speech is 16 kHz mono, motion is 30 frames per second."""
SAMPLE_RATE = 16_000        # Hz: every audio array inside the package
FPS = 30                    # motion frames per second (BEAT2's rate)
