"""Package discovery for setuptools (the rest of the metadata is in pyproject.toml).

The wheel holds one top-level package, `gesturelsm` (the web page is `gesturelsm.webapp`, started by
`gesturelsm serve`); the checkout's `app/` (the `python -m app` launcher, the player's JavaScript sources, developer
tools) stays out of it. Folders outside the package are mapped in, which pyproject.toml alone cannot do while
discovering packages automatically, hence this file:

- the shipped checkpoints and body model (the repository's top-level assets/) become `gesturelsm/_assets/`, which
  `gesturelsm.constants.ASSETS` finds first;
- the in-browser player's bundle, when it was built (app/player/dist/player.js, npm), becomes
  `gesturelsm/webapp/player/player.js`, which `gesturelsm.webapp.motion_player.BUNDLE` finds first; a wheel built
  without it serves the page with the video instead of the player, as a checkout without npm does.

An editable install (`pip install -e .`) leaves assets/ and app/player/dist/ where they are, and both fall back to
them."""
from pathlib import Path

from setuptools import find_namespace_packages, setup

ASSET_PACKAGES = ["gesturelsm._assets"] + [f"gesturelsm._assets.{p}" for p in find_namespace_packages(where="assets")]
SHIPPED = ["*.md", "*.safetensors", "*.npz"]          # model card and notes, checkpoints, the mannequin body model
PLAYER = "gesturelsm.webapp.player"
PLAYER_BUILD = "app/player/dist"
HAS_PLAYER = (Path(__file__).resolve().parent / PLAYER_BUILD / "player.js").is_file()

setup(
    packages=find_namespace_packages(include=["gesturelsm*"]) + ASSET_PACKAGES + [PLAYER] * HAS_PLAYER,
    package_dir={"gesturelsm._assets": "assets", **({PLAYER: PLAYER_BUILD} if HAS_PLAYER else {})},
    package_data={**{p: SHIPPED for p in ASSET_PACKAGES}, "gesturelsm.webapp.examples": ["*.wav", "*.json"],
                  **({PLAYER: ["player.js"]} if HAS_PLAYER else {})},
)
