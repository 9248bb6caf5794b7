"""Our generators on speech of any length, in the shared window loop (`flows.windows`), and decoding.

Windows of t = 32 latents (128 frames) overlap by s = 4 seed latents (16 frames). Window 0 starts from the
neutral seed (no ground truth needed); the overlap each window generates again is cross-faded with the previous
window's version, so there is no jump at borders. Speech features are computed for up to 16 windows per call
(bounded memory), and the conditional and unconditional CFG passes run as one batch. The last window is
padded with silence and cropped.

Edits hold known latents (`held`: the input motion's latents where it is kept, poses pinned by keyframes): only the
windows with latents to regenerate are sampled, and in those the known latents are held to their values noised to
each step's time (flows/base.py `inpainting`), so the regenerated ones are sampled in their context.

Previews: inside `window_previews(listener)` a generation on this thread (not an edit) decodes its latents as each
window makes them final (`WindowDecoder`, the raw motion of the first windows, before any post-processing) and hands
them to the listener while the later windows are sampled; the latents and the motion returned are the same as without.
"""
from __future__ import annotations

import bisect
import contextlib
import math
import threading
from typing import Callable, Iterator, Protocol, Sequence

import torch
import torch.nn.functional as F

from ..constants import Progress
from ..flows import Held, make_method, sample_windows, sampled_windows, window_layout
from ..flows.base import inpainting
from ..kernels import expect
from ..tokenizer.model import quantize_regions
from .data import samples_for
from .model import GestureGenerator


@torch.no_grad()
def generate_latents(model: GestureGenerator, audio_ch: torch.Tensor, words: torch.Tensor, has_word: torch.Tensor,
                     has_text: bool, num_frames: int, steps: int = 8, cfg_scale: float = 2.0, seed: int = 0,
                     progress: Progress | None = None, cond_batch: int = 16, held: Held | None = None,
                     ready_points: Sequence[int] = (), wait: Callable[[int], None] | None = None,
                     on_window: Callable[[torch.Tensor], None] | None = None) -> torch.Tensor:
    """audio_ch (2, N) 16 kHz channels; words (T, 384); has_word (T,). -> (R, ceil(T/4), D) un-scaled latents.
    The speech condition and its contexts are computed for up to `cond_batch` windows at a time (one batched call
    instead of one per window; the windows' denoising stays sequential because each seeds the next), in groups that
    do not straddle a `ready_points` frame count (`cond_groups`). `held`: known un-scaled latents (R, ceil(T/4), D)
    and where they are known (mask broadcastable to them). `wait(n)`: called before a group's condition is computed
    with the frames it reads; returns when `words` and `has_word` are final there (pipelined speech: they are read
    only then, never copied before). `on_window(latents)`: after each window, the un-scaled latents (R, n, D) that
    are final so far (a copy; not for edits), e.g. a `WindowDecoder`."""
    c = model.config
    t, s = c.window_latents, c.seed_latents
    method = make_method(model.method)
    dev = next(model.parameters()).device
    L = math.ceil(num_frames / 4)
    starts = window_layout(L, t, s)
    total = starts[-1] + t                                     # latents covered incl. padding
    n_a = samples_for(4 * t)                                   # samples per window (all windows equal)
    n_samp = samples_for(4 * starts[-1]) + n_a                 # >= samples_for(4 * total): rounding
    audio_ch = F.pad(audio_ch, (0, max(0, n_samp - audio_ch.shape[1])))
    R, D = c.num_regions, c.latent_dim
    std = model.latent_std.cpu()[:, None, None]
    if held is not None:
        held = Held(held.known / std, held.mask)
    todo = sampled_windows(L, t, s, held)
    padded = held.padded(total) if held is not None else None
    need = {i: min(num_frames, 4 * (starts[i] + t)) for i in todo}          # frames of words a window reads
    groups = cond_groups(todo, need, ready_points, cond_batch)
    group_of = {i: g for g in groups for i in g}
    batch: dict = {}

    def sample(i: int, st: int, seed_lat: torch.Tensor, g: torch.Generator) -> torch.Tensor:
        group = group_of[i]
        j = group.index(i)
        if j == 0:                                             # speech condition of the group's windows
            if wait is not None:
                wait(max(need[w] for w in group))
            chunk = [starts[w] for w in group]
            a = torch.stack([audio_ch[:, samples_for(4 * c0):samples_for(4 * c0) + n_a] for c0 in chunk])
            w = torch.stack([_frames(words, 4 * c0, 4 * (c0 + t)) for c0 in chunk])
            hw = torch.stack([_frames(has_word, 4 * c0, 4 * (c0 + t)) for c0 in chunk])
            batch["conds"] = model.speech(a.to(dev), w.to(dev), hw.to(dev),
                                          torch.full((len(chunk),), has_text, device=dev))
            batch["ctx"] = model.contexts(batch["conds"])      # batch n; the null context batch 1
        ctx_c, ctx_u = batch["ctx"]
        noise = torch.randn(1, R, t, D, generator=g).to(dev)
        f = model.bind(batch["conds"][j:j + 1], seed_lat[None].to(dev), (ctx_c.rows(slice(j, j + 1)), ctx_u))
        if padded is not None:
            win = padded.window(st, t)
            f = inpainting(f, method, win.known[None].to(dev), win.mask[None].to(dev), noise)
        return method.sample(f, noise, steps, cfg_scale)[0]                                 # (R, t, D) scaled

    hook = None if on_window is None or held is not None else \
        (lambda n, out: on_window(out[:, :min(n, L)] * std))
    with expect(len(todo) * steps):                            # the trunk's calls ahead (kernels.choice.Switch)
        out = sample_windows(L, t, s, model.neutral_seed.cpu(), sample, seed, crossfade=True, progress=progress,
                             held=held, on_window=hook)
    return out[:, :L] * std


def cond_groups(todo: list[int], need: dict[int, int], ready_points: Sequence[int], size: int) -> list[list[int]]:
    """The windows `todo` in order, in runs of at most `size` whose frames (`need`) become final at the same
    `ready_points` step (all in one step when there are none)."""
    step = (lambda i: bisect.bisect_left(ready_points, need[i])) if ready_points else (lambda i: 0)
    groups: list[list[int]] = []
    for i in todo:
        if groups and len(groups[-1]) < size and step(groups[-1][0]) == step(i):
            groups[-1].append(i)
        else:
            groups.append([i])
    return groups


def _frames(x: torch.Tensor, lo: int, hi: int) -> torch.Tensor:
    """x[lo:hi] along dim 0, zero-padded past its end."""
    part = x[lo:hi]
    return F.pad(part, (0, 0) * (x.ndim - 1) + (0, hi - lo - part.shape[0])) if part.shape[0] < hi - lo else part


@torch.no_grad()
def decode_latents(tokenizers: dict, latents: torch.Tensor, num_frames: int, chunk: int = 512, margin: int = 16
                   ) -> dict[str, torch.Tensor]:
    """(R, L, D) latents -> {region: (T, C) raw features}; decoded in chunks of `chunk` latents with `margin`
    latents of context each side (cropped), so memory is bounded for any length. Re-quantises first, all regions in one
    stacked pass when their quantizers have the same shape (`quantize_stacked`)."""
    toks = list(tokenizers.values())
    pieces: list[list[torch.Tensor]] = [[] for _ in toks]
    L = latents.shape[1]
    for a in range(0, L, chunk):
        lo, hi = max(0, a - margin), min(L, a + chunk + margin)
        z = latents[:, lo:hi]                                             # (R, n, D)
        qs = quantize_regions(toks, z)
        for r, (t, q) in enumerate(zip(toks, qs)):
            y = t.decode(q.reshape(1, hi - lo, -1))[0]                    # (4 (hi - lo), C) normalised
            pieces[r].append(y[4 * (a - lo):4 * (a - lo) + 4 * min(chunk, L - a)])
    return {region: t.normalizer.denormalize(torch.cat(p)[:num_frames])
            for (region, t), p in zip(tokenizers.items(), pieces)}


class PreviewListener(Protocol):
    """What `window_previews` hands the decoded windows to."""

    def wanted(self) -> bool:
        """Whether previews are still wanted (False: nothing more is decoded for them)."""

    def show(self, parts: dict[str, torch.Tensor]) -> None:
        """The raw decoded motion so far: {region: (frames, C) features}, from frame 0, growing call by call."""

# A listener may also have `context_after` (latents, default 0): frames are shown once that many final latents follow
# them, so that they are decoded with the context after them too (16, decode_latents' margin: as the whole motion is
# decoded, to float rounding), at the cost of showing them that much later.


_listening = threading.local()


@contextlib.contextmanager
def window_previews(listener: PreviewListener) -> Iterator[None]:
    """Inside: our generators on this thread hand `listener` their motion window by window (module docstring)."""
    before = getattr(_listening, "listener", None)
    _listening.listener = listener
    try:
        yield
    finally:
        _listening.listener = before


def window_decoder(tokenizers: dict, num_frames: int) -> "WindowDecoder | None":
    """The `on_window` of a generation on this thread: a `WindowDecoder` for the listener of `window_previews`, None
    outside one."""
    listener = getattr(_listening, "listener", None)
    return None if listener is None else WindowDecoder(tokenizers, num_frames, listener,
                                                       after=getattr(listener, "context_after", 0))


class WindowDecoder:
    """Decodes the final latents of a generation as they grow, only the new ones each time (with `margin` latents of
    context before them), and shows the listener the raw motion so far. With `after` 0 the last frames of a call are
    decoded without the context after them, so they may differ a little from the whole motion's decoding (a preview);
    with `after` > 0 only the frames that many final latents precede are shown, decoded with them as context."""

    def __init__(self, tokenizers: dict, num_frames: int, listener: PreviewListener, margin: int = 16,
                 after: int = 0):
        self.tokenizers, self.num_frames, self.listener, self.margin = tokenizers, num_frames, listener, margin
        self.after = after
        self.pieces: dict[str, list[torch.Tensor]] = {r: [] for r in tokenizers}
        self.done = 0

    @torch.no_grad()
    def __call__(self, latents: torch.Tensor) -> None:
        n = latents.shape[1]
        upto = n - self.after                         # latents shown after this call
        if upto <= self.done or 4 * n >= self.num_frames or not self.listener.wanted():
            return                                    # the whole motion: it is finished moments later
        lo = max(0, self.done - self.margin)
        device = next(next(iter(self.tokenizers.values())).parameters()).device
        parts = decode_latents(self.tokenizers, latents[:, lo:n].to(device), 4 * (n - lo))
        for region, y in parts.items():
            self.pieces[region].append(y[4 * (self.done - lo):4 * (upto - lo)].cpu())
        self.done = upto
        frames = min(self.num_frames, 4 * upto)
        self.listener.show({r: torch.cat(p)[:frames] for r, p in self.pieces.items()})
