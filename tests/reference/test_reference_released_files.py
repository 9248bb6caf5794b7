"""The vocabulary unpickler: a `Vocab` pickled with any protocol (0-5) loads to the same words and embedding;
code, foreign classes and misuse of the globals it allows are refused without running anything."""
from __future__ import annotations

import os
import pickle
import sys
import types
from pathlib import Path

import numpy as np
import pytest

from gesturelsm.reference.released_files import ReferenceFileError, load_vocab

FIX = Path(__file__).parent / "fixtures"


@pytest.fixture()
def vocab_class(monkeypatch):
    """A class importable as `dataloaders.build_vocab.Vocab`, as the authors' code defines it (pickle needs the
    class importable under that name to write it)."""
    pkg, mod = types.ModuleType("dataloaders"), types.ModuleType("dataloaders.build_vocab")

    class Vocab:
        def __init__(self, words: list[str], dim: int = 300):
            self.name = "beat"
            self.word2index = {w: i for i, w in enumerate(words)}
            self.index2word = dict(enumerate(words))
            self.n_words = len(words)
            self.word_embedding_weights = np.random.default_rng(0).normal(size=(len(words), dim)).astype(np.float32)

    Vocab.__module__, Vocab.__qualname__ = "dataloaders.build_vocab", "Vocab"
    mod.Vocab, pkg.build_vocab = Vocab, mod
    monkeypatch.setitem(sys.modules, "dataloaders", pkg)
    monkeypatch.setitem(sys.modules, "dataloaders.build_vocab", mod)
    return Vocab


@pytest.mark.parametrize("protocol", range(0, pickle.HIGHEST_PROTOCOL + 1))
def test_every_pickle_protocol_loads_the_same_vocabulary(tmp_path, vocab_class, protocol):
    v = vocab_class(["hello", "world", "gesture", "naïve"])
    p = tmp_path / "vocab.pkl"
    p.write_bytes(pickle.dumps(v, protocol=protocol))
    if protocol <= 2:
        assert b"_codecs" in p.read_bytes()          # bytes stored through _codecs.encode
    w2i, emb = load_vocab(p)
    assert w2i == v.word2index
    np.testing.assert_array_equal(emb, v.word_embedding_weights)


def test_the_recorded_vocabulary_still_loads():
    w2i, emb = load_vocab(FIX / "vocab.pkl")
    assert len(w2i) == 6 and emb.shape == (max(w2i.values()) + 1, 300)


class _Evil:
    def __reduce__(self):
        return (os.system, ("touch /tmp/gesturelsm_pwned_marker_pickle",))


@pytest.mark.parametrize("protocol", [0, 2, pickle.HIGHEST_PROTOCOL])
def test_a_pickle_with_code_is_refused_at_every_protocol(tmp_path, protocol):
    marker = Path("/tmp/gesturelsm_pwned_marker_pickle")
    marker.unlink(missing_ok=True)
    p = tmp_path / "vocab.pkl"
    p.write_bytes(pickle.dumps({"word2index": _Evil()}, protocol=protocol))
    with pytest.raises(ReferenceFileError, match="not allowed"):
        load_vocab(p)
    assert not marker.exists()


def test_the_allowed_reconstructor_builds_nothing_but_a_vocabulary(tmp_path):
    """copyreg._reconstructor (protocols 0-1) is allowed only for the stand-in classes (here the Vocab record):
    asking it for another class (a list built from object) is refused."""
    p = tmp_path / "vocab.pkl"
    p.write_bytes(b"ccopy_reg\n_reconstructor\n(c__builtin__\nlist\nc__builtin__\nobject\nNtR.")
    with pytest.raises(ReferenceFileError, match="only for a plain instance of a stand-in class"):
        load_vocab(p)


def test_codecs_encode_cannot_reach_other_globals(tmp_path):
    p = tmp_path / "vocab.pkl"
    p.write_bytes(b"c_codecs\ndecode\n(Vx\nVutf-8\ntR.")          # decode is not on the list
    with pytest.raises(ReferenceFileError, match="not allowed"):
        load_vocab(p)
