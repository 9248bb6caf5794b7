"""Package discovery for setuptools (the rest of the metadata is in pyproject.toml).

The shipped checkpoints and body model stay in the repository's top-level assets/; a wheel carries them as
`gesturelsm/_assets/`, which `gesturelsm.constants.ASSETS` finds first. pyproject.toml alone cannot map a folder
outside the package into it while discovering packages automatically, hence this file. An editable install
(`pip install -e .`) leaves assets/ where it is, and ASSETS falls back to it."""
from setuptools import find_namespace_packages, setup

ASSET_PACKAGES = ["gesturelsm._assets"] + [f"gesturelsm._assets.{p}" for p in find_namespace_packages(where="assets")]
SHIPPED = ["*.md", "*.safetensors", "*.npz"]          # model card and notes, checkpoints, the mannequin body model

setup(
    packages=find_namespace_packages(include=["gesturelsm*", "app*"], exclude=["app.player.node_modules*"])
    + ASSET_PACKAGES,
    package_dir={"gesturelsm._assets": "assets"},
    package_data={p: SHIPPED for p in ASSET_PACKAGES},
)
