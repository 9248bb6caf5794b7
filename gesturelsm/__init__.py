"""GestureLSM: speech-to-gesture generation."""
