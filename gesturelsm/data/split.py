"""Training data for the tokenizers and the generator: train / held-out frames of a BEAT2-layout folder.

Split policy: a folder with `train_test_split.csv` uses its `train` takes for training and `val`/`test`
for held-out; without one (e.g. the single real take shipped beside this project) the first
`train_fraction` of every take trains and the rest is held out.
"""
from __future__ import annotations

from dataclasses import dataclass

import torch

from ..errors import DatasetError
from .beat2 import Beat2Dataset
from ..motion.sequence import mirror_features


@dataclass
class Split:
    train: list[torch.Tensor]     # raw (T_i, 433) feature sequences
    heldout: list[torch.Tensor]
    train_names: list[str]
    heldout_names: list[str]
    policy: str                   # human-readable description, stored in checkpoints


def split_features(root, train_fraction: float = 0.8, speakers=None, cache_dir=None) -> Split:
    ds = Beat2Dataset(root, speakers=speakers, cache_dir=cache_dir)
    if not ds.names:
        raise DatasetError(f"{root}: no motion takes (smplxflame_30/*.npz) found")
    if ds.splits:
        train = [n for n in ds.names if ds.splits.get(n) == "train"]
        held = [n for n in ds.names if ds.splits.get(n) in ("val", "test")]
        return Split([ds.features(n) for n in train], [ds.features(n) for n in held], train, held,
                     "train_test_split.csv: train vs val+test")
    tr, ho = [], []
    for n in ds.names:
        f = ds.features(n)
        cut = int(round(train_fraction * f.shape[0]))
        tr.append(f[:cut])
        ho.append(f[cut:])
    pct = round(100 * train_fraction)
    return Split(tr, ho, list(ds.names), list(ds.names),
                 f"first {pct}% of each take trains, last {100 - pct}% held out")


class WindowSampler:
    """Random crops of `length` frames from a list of sequences, mirrored with probability 0.5."""

    def __init__(self, seqs: list[torch.Tensor], length: int, mirror: bool = True, seed: int = 0):
        self.seqs = [s for s in seqs if s.shape[0] >= length]
        if not self.seqs:
            raise DatasetError(f"no training sequence is at least {length} frames long")
        self.length, self.mirror = length, mirror
        self.g = torch.Generator().manual_seed(seed)
        lens = torch.tensor([s.shape[0] - length + 1 for s in self.seqs], dtype=torch.float)
        self.weights = lens / lens.sum()  # uniform over all possible windows

    def sample(self, batch: int) -> torch.Tensor:
        """-> (batch, length, 433) raw features."""
        which = torch.multinomial(self.weights, batch, replacement=True, generator=self.g)
        out = []
        for i in which.tolist():
            s = self.seqs[i]
            start = int(torch.randint(0, s.shape[0] - self.length + 1, (1,), generator=self.g))
            w = s[start:start + self.length]
            if self.mirror and torch.rand((), generator=self.g) < 0.5:
                w = mirror_features(w)
            out.append(w)
        return torch.stack(out)

    def state(self) -> torch.Tensor:
        return self.g.get_state()

    def set_state(self, st: torch.Tensor) -> None:
        self.g.set_state(st)
