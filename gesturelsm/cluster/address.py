"""Where distributed work runs: the `--cluster` value of `gesturelsm batch / sweep / eval` and `python -m app`.

    local            start a Ray cluster on this machine with its cores, for this command only
    auto             join the cluster that `ray start --head` started on this machine (or RAY_ADDRESS)
    ray://HOST:PORT  a remote cluster through its Ray Client server (`ray start --head` listens on port 10001)

The web demo's `--replicas N` or `MIN:MAX` is parsed here too. Parsing needs nothing of Ray: a bad value is refused
before anything is imported or started.
"""
from __future__ import annotations

import argparse
import re
from dataclasses import dataclass

from ..errors import ClusterError

CLIENT_PORT = 10001                     # the Ray Client server's port on a head started by `ray start --head`
FORMS = "local, auto or ray://HOST:PORT"
_CLIENT = re.compile(r"^ray://(?P<host>\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+)(?::(?P<port>[^/]*))?/?$")


@dataclass(frozen=True)
class ClusterAddress:
    kind: str                   # "local", "auto" or "client"
    host: str | None = None     # client only
    port: int | None = None     # client only

    @property
    def ray_address(self) -> str:
        """What `ray.init(address=...)` takes: "local" starts a new cluster even when RAY_ADDRESS is set."""
        return f"ray://{self.host}:{self.port}" if self.kind == "client" else self.kind

    def __str__(self) -> str:
        return self.ray_address


def parse_cluster(text: str | None) -> ClusterAddress:
    """'local' | 'auto' | 'ray://HOST:PORT' (PORT defaults to 10001) -> ClusterAddress; anything else is a
    ClusterError naming the accepted forms."""
    value = (text or "").strip()
    if value.lower() in ("local", "auto"):
        return ClusterAddress(value.lower())
    m = _CLIENT.match(value)
    if not m:
        hint = " (a remote cluster is written ray://HOST:PORT)" if value and "://" not in value else ""
        raise ClusterError(f"--cluster must be {FORMS} (got {value!r}){hint}")
    port_text = m.group("port")
    if port_text is None or port_text == "":
        port = CLIENT_PORT
    elif port_text.isdigit() and 1 <= int(port_text) <= 65535:
        port = int(port_text)
    else:
        raise ClusterError(f"--cluster {value}: the port must be a number from 1 to 65535 (got {port_text!r})")
    return ClusterAddress("client", m.group("host").strip("[]"), port)


@dataclass(frozen=True)
class ReplicaCount:
    """`--replicas N` (fixed) or `MIN:MAX` (autoscaled on the number of requests waiting per replica)."""
    low: int
    high: int

    @property
    def fixed(self) -> bool:
        return self.low == self.high

    def __str__(self) -> str:
        return str(self.low) if self.fixed else f"{self.low}:{self.high}"


MAX_REPLICAS = 256


def parse_replicas(text: str | int) -> ReplicaCount:
    """'3' -> 3 replicas; '1:4' -> from 1 to 4 as the queue asks; anything else is a ClusterError."""
    value = str(text).strip()
    parts = value.split(":")
    if len(parts) > 2 or not all(p.strip().isdigit() for p in parts):
        raise ClusterError(f"--replicas must be a whole number N or MIN:MAX (got {value!r})")
    low, high = int(parts[0]), int(parts[-1])
    if not 1 <= low <= high <= MAX_REPLICAS:
        raise ClusterError(f"--replicas {value}: give 1 to {MAX_REPLICAS} replicas, MIN at most MAX")
    return ReplicaCount(low, high)


def replicas_argument(text: str) -> ReplicaCount:
    try:
        return parse_replicas(text)
    except ClusterError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def cluster_argument(text: str) -> ClusterAddress:
    """argparse `type=`: a bad value becomes argparse's one-line usage error."""
    try:
        return parse_cluster(text)
    except ClusterError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_cluster_argument(parser: argparse.ArgumentParser, what: str, default: str | None = None) -> None:
    """The one `--cluster` flag every distributed command takes; `what` says what becomes a task."""
    parser.add_argument("--cluster", type=cluster_argument, default=default, metavar="local|auto|ray://HOST:PORT",
                        help=f"run {what} as tasks on a Ray cluster: local (start one on this machine's cores), auto "
                             "(join the one `ray start --head` started here), or ray://HOST:PORT (a remote one); "
                             "without it everything runs in this process (docs/CLUSTER.md)")


__all__ = ["CLIENT_PORT", "ClusterAddress", "ReplicaCount", "add_cluster_argument", "cluster_argument",
           "parse_cluster", "parse_replicas", "replicas_argument"]
