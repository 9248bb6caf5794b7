"""The shipped tokenizers: loadable, small, and accurate on the held-out part of the real take."""
from pathlib import Path

import pytest

from gesturelsm.motion.regions import GENERATED_REGIONS
from gesturelsm.tokenizer import RVQVAE

ASSETS = Path(__file__).resolve().parents[2] / "assets"
# held-out mean rotation error (deg) the shipped files must stay under (measured: upper 1.30, hands 1.89,
# lower 0.82, face 0.10 with `gesturelsm eval-tokenizer --data ../shared/data/beat2`)
LIMITS = {"upper": 1.6, "hands": 2.2, "lower": 1.1, "face": 0.3}


def test_all_shipped_weights_stay_small():
    total = sum(p.stat().st_size for p in ASSETS.rglob("*") if p.is_file())
    assert total < 40e6, f"assets/ holds {total / 1e6:.1f} MB"


@pytest.mark.parametrize("region", GENERATED_REGIONS)
def test_shipped_tokenizer_reconstructs_held_out_motion(region, beat2_root):
    from gesturelsm.data.split import split_features
    from gesturelsm.tokenizer.evaluate import reconstruction_error

    model = RVQVAE.load(ASSETS / "tokenizer" / f"{region}.safetensors")
    assert model.region == region and model.config.groups == 32
    split = split_features(beat2_root)
    err = reconstruction_error(model, split.heldout)
    assert err < LIMITS[region], err
