"""EMAGE's skeleton-conv encoder: its published weights (AESKConv_240_100.bin) are not reachable here, so the
architecture is checked against facts of the published model (55 edges -> 240 features per 16 frames,
GroupNorm(10)-compatible widths, locality of the masked convolutions) and the loading path on a state dict
saved by the test in the published file's layout."""
import numpy as np
import pytest
import torch

from gesturelsm.metrics.emage_fgd import (SkeletonConvEncoder, edge_neighbours, emage_features, load_emage_weights,
                                          pooling_groups, skeleton_edges)
from gesturelsm.metrics.fgd import EmageExtractor, fgd
from gesturelsm.motion.skeleton import PARENTS


@pytest.fixture(scope="module")
def encoder():
    torch.manual_seed(0)
    return SkeletonConvEncoder().eval()


def test_published_shapes(encoder):
    assert encoder.in_dim == 330 and encoder.latent_dim == 240 and encoder.stride == 16
    with torch.no_grad():
        assert encoder(torch.randn(2, 64, 330)).shape == (2, 4, 240)
    edges = skeleton_edges(PARENTS)
    groups, pooled = pooling_groups(edges, last=False)
    assert len(edges) == 55 and len(groups) == 35 and sorted(sum(groups, [])) == list(range(55))


def test_skeleton_locality():
    edges = skeleton_edges(PARENTS)
    nb = edge_neighbours(edges, 2)
    assert 20 in nb[18] and 21 not in nb[18]          # left elbow sees its wrist, not the right wrist
    assert 15 in nb[12] and 0 not in nb[15]           # neck -> head: 1 hop; head -> root: too far


def test_masked_conv_is_local(encoder):
    """Changing the right hand's rotations leaves the first layer's left-leg outputs unchanged."""
    block = encoder.layers[0][0]
    x = torch.randn(1, 330, 16)
    y = x.clone()
    y[:, 6 * 40:6 * 55] += 1.0                        # right-hand joints 40..54
    with torch.no_grad():
        a, b = block.residual[0](x), block.residual[0](y)
    left_leg = slice(6 * 1, 6 * 2)                    # output edge 1 (left hip)
    assert torch.allclose(a[:, left_leg], b[:, left_leg])
    assert not torch.allclose(a[:, 6 * 40:6 * 41], b[:, 6 * 40:6 * 41])


def test_loads_a_checkpoint_in_the_published_layout(encoder, tmp_path):
    """Keys under 'model_state' with DataParallel's 'module.encoder.' prefix, plus decoder / VAE-head weights
    that FGD does not need."""
    state = {f"module.encoder.{k}": v.clone() for k, v in encoder.state_dict().items()}
    state["module.fc_mu.weight"] = torch.zeros(240, 240)
    state["module.decoder.main.0.weight"] = torch.zeros(3, 3)
    path = tmp_path / "AESKConv_240_100.bin"
    torch.save({"model_state": state, "epoch": 100}, path)
    torch.manual_seed(123)
    fresh = SkeletonConvEncoder()
    x = np.random.default_rng(0).normal(size=(96, 330))
    assert not np.allclose(emage_features(fresh, x), emage_features(encoder, x))
    load_emage_weights(fresh, path)
    assert np.allclose(emage_features(fresh, x), emage_features(encoder, x), atol=1e-6)
    ex = EmageExtractor(path)

    class M:
        def to_features(self):
            return torch.as_tensor(x, dtype=torch.float32)
    f = ex(M(), None)
    assert f.shape == (6, 240) and fgd([f], [f]) == pytest.approx(0.0, abs=1e-8)


def test_rejects_other_checkpoints(encoder):
    with pytest.raises(ValueError, match="encoder"):
        load_emage_weights(SkeletonConvEncoder(), {"model_state": {"decoder.w": torch.zeros(1)}})
    bad = {f"encoder.{k}": v for k, v in encoder.state_dict().items()}
    bad["encoder.layers.0.0.residual.0.weight"] = torch.zeros(3, 3, 4)
    with pytest.raises(ValueError, match="architecture"):
        load_emage_weights(SkeletonConvEncoder(), bad)
