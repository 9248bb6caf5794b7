"""The authors' released GestureLSM models, computed exactly as their public code computes them.

Reference: github.com/andypinxinliu/GestureLSM at upstream commit fe124e0 (Sept 2025). Our own code,
written from reading theirs; equality with their code is tested on recorded inputs/outputs
(tests/reference/fixtures). Differences from our own architecture are kept on purpose here, because the
released weights were trained with them (see `denoiser.py` and `speech.py` for each quirk).

Conventions of the reference (not ours): the shortcut model runs t = 0 noise -> t = 1 data, MeanFlow
runs t = 1 noise -> t = 0 data, the diffusion model sees integer steps 0..999. Latents: per window
(B, 3 * 128, 32) channel-major, regions [upper, hands, lower], 32 latent frames at 7.5 Hz; the
generator works on the RVQ encoder output divided by 5.
"""
