"""Generator configuration and named presets."""
from __future__ import annotations

from dataclasses import dataclass

from ..motion.regions import GENERATED_REGIONS


@dataclass(frozen=True)
class GeneratorConfig:
    regions: tuple[str, ...] = GENERATED_REGIONS   # one token per region per latent frame (+Face: 4)
    latent_dim: int = 128          # tokenizer latent size per region
    window_latents: int = 32       # 128 frames at 30 fps / 4
    seed_latents: int = 4          # overlap with the previous window, given as context (16 frames)
    dim: int = 256                 # transformer width
    heads: int = 4
    cross_layers: int = 3
    st_layers: int = 8
    ffn: int = 1024
    drop_path: float = 0.1
    audio_channels: tuple[int, ...] = (64, 64, 64, 128, 128, 256)
    audio_pool: int = 1            # 4: max-pool the audio channels to 4 kHz before the strided convs
    text_in: int = 384             # MiniLM word vectors
    text_dim: int = 256
    cond_dim: int = 768            # fused speech feature per latent frame
    uses_step_size: bool = True    # shortcut models take d; baselines do not
    # what the flow models' network outputs: "velocity" (the paper) or "data", the clean latents x1, turned
    # into the velocity (x1_hat - x_t) / (1 - t) (flows/base.velocity_from_data). DDIM always predicts data.
    prediction: str = "velocity"
    # frame-aligned speech: besides the cross-attention, add each latent frame's (LayerNorm + linear projected)
    # speech feature to that frame's tokens. Cross-attention alone must learn which speech frame belongs to
    # which gesture frame from learned absolute positions. Not used by the shipped models: on the 51 s take a
    # 600-step probe with it gave no timing gain and twice the jitter (see the model card); for larger data.
    speech_add: bool = False

    @property
    def window_frames(self) -> int:
        return self.window_latents * 4

    @property
    def num_regions(self) -> int:
        return len(self.regions)


PRESETS: dict[str, GeneratorConfig] = {
    "tiny": GeneratorConfig(latent_dim=16, window_latents=8, seed_latents=2, dim=32, heads=2, cross_layers=1,
                            st_layers=1, ffn=64, drop_path=0.0, audio_channels=(8, 8, 8, 16, 16, 16),
                            text_dim=16, cond_dim=32),
    # the paper's sizes: 3 cross + 8 spatial-temporal layers, width 256, FFN 1024 (~30M with the face region)
    "paper": GeneratorConfig(),
    # shipped: same structure, narrower and shallower, trained on one speaker's minute of motion on 2 CPU cores
    "small": GeneratorConfig(dim=128, heads=4, cross_layers=2, st_layers=4, ffn=512, drop_path=0.1,
                             audio_channels=(16, 16, 32, 32, 64, 128), audio_pool=4, text_dim=128, cond_dim=256),
}
