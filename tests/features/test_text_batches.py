"""The bounded-context text features encode their blocks in batched encoder calls: a block's numbers must not depend on
which blocks share its call (the pipelined path encodes the blocks as their words arrive, the one-shot path all at
once, and both must give the same bits), and must equal one plain encoder pass per block up to float rounding."""
import threading

import numpy as np
import pytest
import torch

from gesturelsm.features.text import MAX_TOKENS, PAD_TO, TextEmbedder, padded_length

COMMON = "the cat sat on a mat and we went to see it in the park with my friend who has one dog".split()


def _embedder() -> TextEmbedder:
    emb = TextEmbedder.shared()
    if not emb.available:
        pytest.skip(f"text encoder not installed: {emb.error}")
    return emb


def _contexts() -> tuple[list[list[str]], list[range]]:
    """Contexts of several token counts, among them exact multiples of PAD_TO (common words: one token each, plus the
    two special tokens), and the words of each to keep."""
    sizes = (1, 6, 14, 9, 22, 6, 30, 3)                    # 6 and 14 words: 8 and 16 tokens
    contexts = [[COMMON[(i + k) % len(COMMON)] for k in range(n)] for i, n in enumerate(sizes)]
    keeps = [range(n // 3, max(n // 3 + 1, 2 * n // 3)) for n in sizes]
    return contexts, keeps


def test_padded_length_always_pads_and_stays_within_the_encoder():
    for n in range(1, MAX_TOKENS):
        p = padded_length(n)
        assert p > n and p % PAD_TO == 0 and p <= MAX_TOKENS
    assert padded_length(MAX_TOKENS - 1) == MAX_TOKENS


def test_a_block_gives_the_same_bits_in_any_batch_and_on_any_thread():
    emb = _embedder()
    contexts, keeps = _contexts()
    threads = torch.get_num_threads()
    torch.set_num_threads(2)                              # all at once on two math threads ...
    try:
        together = emb.embed_blocks(contexts, keeps)
    finally:
        torch.set_num_threads(threads)
    one_by_one = [emb.embed_blocks([c], [k])[0] for c, k in zip(contexts, keeps)]
    backwards = emb.embed_blocks(contexts[::-1], keeps[::-1])[::-1]
    pairs = [v for i in range(0, len(contexts), 2) for v in emb.embed_blocks(contexts[i:i + 2], keeps[i:i + 2])]
    on_thread: list[np.ndarray] = []

    def words_thread():                                   # ... and on another thread with one
        torch.set_num_threads(1)
        on_thread.extend(emb.embed_blocks(contexts[1:5], keeps[1:5]))

    t = threading.Thread(target=words_thread)
    t.start()
    t.join()
    for got in (one_by_one, backwards, pairs):
        assert all(np.array_equal(a, b) for a, b in zip(together, got))
    assert all(np.array_equal(a, b) for a, b in zip(together[1:5], on_thread))
    assert all(a.shape == (len(k), 384) and (np.linalg.norm(a, axis=1) > 0).all() for a, k in zip(together, keeps))


@torch.no_grad()
def test_batched_blocks_equal_one_plain_pass_per_block_up_to_float_rounding():
    emb = _embedder()
    contexts, keeps = _contexts()
    batched = emb.embed_blocks(contexts, keeps)
    for c, k, got in zip(contexts, keeps, batched):
        enc = emb._tok(c, is_split_into_words=True, return_tensors="pt")
        h = emb._model(**enc).last_hidden_state[0]        # unpadded, no attention mask, batch of one
        ids = enc.word_ids()
        plain = np.stack([h[[i for i, w in enumerate(ids) if w == local]].mean(0).numpy() for local in k])
        assert np.allclose(got, plain, rtol=0, atol=1e-4)
    assert np.array_equal(emb.embed_in_context(contexts[2], keeps[2]), batched[2])


def test_threads_asking_for_the_encoder_at_once_load_it_once(monkeypatch):
    """`gesturelsm generate` loads the encoder on a thread while the pipeline's warm-up asks for it too."""
    if not _embedder().available:
        pytest.skip("text encoder not installed")
    emb, loads = TextEmbedder(), []
    real = emb._load_now
    monkeypatch.setattr(emb, "_load_now", lambda: (loads.append(1), real()))
    threads = [threading.Thread(target=lambda: emb.available) for _ in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert emb.available and loads == [1]
