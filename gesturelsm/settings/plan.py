"""What one request makes from one prepared speech (`GesturePipeline.generate_each`): its settings
and where the ground truth of a known take is looked up."""
from __future__ import annotations

from dataclasses import dataclass

from .defaults import DEFAULTS, Settings


@dataclass(frozen=True)
class Plan:
    """What to make from one prepared speech: the settings (methods, steps, CFG, seed, post-processing) and where
    the ground truth of a known take is looked up."""
    settings: Settings = DEFAULTS
    beat2: str | None = None                   # BEAT2-layout folder where GROUND_TRUTH is looked up
    filename: str | None = None                # the speech file's name (a take is recognised by it first)

    @property
    def methods(self) -> tuple[str, ...]:
        return self.settings.methods

    @property
    def generators(self) -> list[str]:
        return self.settings.generators

    def steps_for(self, method: str) -> int:
        return self.settings.steps_for(method)


__all__ = ["Plan"]
