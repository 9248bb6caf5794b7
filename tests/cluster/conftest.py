"""One simulated Ray cluster (two nodes of one CPU each, ray.cluster_utils.Cluster) shared by the tests of this
folder that ask for it, stopped when they are done; tests/conftest.py marks them slow and keeps them in one test
process."""
from __future__ import annotations

import pytest

import _cluster_support


@pytest.fixture(scope="package")
def ray_cluster():
    with _cluster_support.ray_cluster(nodes=2) as cluster:
        yield cluster
