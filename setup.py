"""Package discovery for setuptools (the rest of the metadata is in pyproject.toml).

The wheel holds one top-level package, `gesturelsm` (the web page is `gesturelsm.webapp`, started by
`gesturelsm serve`); the checkout's `app/` (the `python -m app` launcher and developer tools) stays out of it. What
pyproject.toml alone cannot say while discovering packages automatically, hence this file:

- the shipped checkpoints and body model (the repository's top-level assets/) become `gesturelsm/_assets/`, which
  `gesturelsm.constants.ASSETS` finds first;
- the in-browser player's bundle, when it was built (gesturelsm/webapp/player/dist/player.js, npm), is package data
  of `gesturelsm.webapp.player`; its JavaScript sources and npm packages are not. A wheel built without the bundle
  serves the page with the video instead of the player, as a checkout without npm does.

An editable install (`pip install -e .`) leaves assets/ where it is, and `ASSETS` falls back to it."""
from setuptools import find_namespace_packages, setup

ASSET_PACKAGES = ["gesturelsm._assets"] + [f"gesturelsm._assets.{p}" for p in find_namespace_packages(where="assets")]
SHIPPED = ["*.md", "*.safetensors", "*.npz"]          # model card and notes, checkpoints, the mannequin body model
PLAYER = "gesturelsm.webapp.player"
NOT_PYTHON = [f"{PLAYER}.{d}" for d in ("src", "dist", "node_modules")] + [f"{PLAYER}.node_modules.*"]

setup(
    packages=find_namespace_packages(include=["gesturelsm*"], exclude=NOT_PYTHON) + ASSET_PACKAGES,
    package_dir={"gesturelsm._assets": "assets"},
    package_data={**{p: SHIPPED for p in ASSET_PACKAGES}, "gesturelsm.webapp.examples": ["*.wav", "*.json"],
                  PLAYER: ["dist/player.js"]},
)
