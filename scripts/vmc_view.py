"""A VMC receiver of our own, for a look at what a stream carries: listens on a UDP port, decodes the bundles with a
small OSC decoder (struct only: not our sender's library), puts the received local bone poses on the skeleton they
describe (forward kinematics in Unity's left-handed frame) and draws frames of it with matplotlib, from behind and
from the side, with the VRM blendshapes received, into a PNG.

    python scripts/vmc_view.py --port 39539 --out docs/engines.png &      # listen
    gesturelsm stream take.npz --vmc 127.0.0.1:39539                      # send
It stops after --seconds, or 2 s after the last bundle.
"""
from __future__ import annotations

import argparse
import socket
import struct
import time

import numpy as np
from scipy.spatial.transform import Rotation


def _string(data: bytes, i: int) -> tuple[str, int]:
    end = data.index(b"\0", i)
    return data[i:end].decode("utf-8"), i + ((end - i) // 4 + 1) * 4


def decode_message(data: bytes) -> tuple[str, list]:
    address, i = _string(data, 0)
    tags, i = _string(data, i)
    args = []
    for t in tags[1:]:
        if t in "fi":
            args.append(struct.unpack(">" + t, data[i:i + 4])[0])
            i += 4
        elif t == "s":
            s, i = _string(data, i)
            args.append(s)
    return address, args


def decode_bundle(data: bytes) -> list[tuple[str, list]]:
    if not data.startswith(b"#bundle"):
        return [decode_message(data)]
    i, out = 16, []
    while i < len(data):
        (n,) = struct.unpack(">i", data[i:i + 4])
        out += decode_bundle(data[i + 4:i + 4 + n])
        i += 4 + n
    return out


# each HumanBodyBones bone's parent (the humanoid's hierarchy, as Unity's Avatar has it)
PARENT = {"Hips": None, "Spine": "Hips", "Chest": "Spine", "UpperChest": "Chest", "Neck": "UpperChest",
          "Head": "Neck", "Jaw": "Head", "LeftEye": "Head", "RightEye": "Head"}
for _S in ("Left", "Right"):
    PARENT.update({f"{_S}UpperLeg": "Hips", f"{_S}LowerLeg": f"{_S}UpperLeg", f"{_S}Foot": f"{_S}LowerLeg",
                   f"{_S}Toes": f"{_S}Foot", f"{_S}Shoulder": "UpperChest", f"{_S}UpperArm": f"{_S}Shoulder",
                   f"{_S}LowerArm": f"{_S}UpperArm", f"{_S}Hand": f"{_S}LowerArm"})
    for _F in ("Thumb", "Index", "Middle", "Ring", "Little"):
        PARENT[f"{_S}{_F}Proximal"] = f"{_S}Hand"
        PARENT[f"{_S}{_F}Intermediate"] = f"{_S}{_F}Proximal"
        PARENT[f"{_S}{_F}Distal"] = f"{_S}{_F}Intermediate"


def world_positions(bones: dict[str, tuple[np.ndarray, np.ndarray]]) -> dict[str, np.ndarray]:
    """Forward kinematics of the received local poses (Unity's frame, metres)."""
    G, P = {}, {}
    for name in PARENT:                        # parents come first in PARENT's order
        if name not in bones:
            continue
        pos, q = bones[name]
        R = Rotation.from_quat(q)
        p = PARENT[name]
        if p is None or p not in G:
            G[name], P[name] = R, pos
        else:
            G[name], P[name] = G[p] * R, P[p] + G[p].apply(pos)
    return P


def listen(port: int, seconds: float) -> list[dict]:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("0.0.0.0", port))
    sock.settimeout(0.2)
    frames, start, last = [], time.time(), None
    while time.time() - start < seconds and (last is None or time.time() - last < 2.0):
        try:
            data = sock.recv(65536)
        except socket.timeout:
            continue
        last = time.time()
        frame = {"bones": {}, "blends": {}, "t": None, "at": last}
        for address, args in decode_bundle(data):
            if address == "/VMC/Ext/Bone/Pos":
                frame["bones"][args[0]] = (np.array(args[1:4]), np.array(args[4:8]))
            elif address == "/VMC/Ext/Blend/Val":
                frame["blends"][args[0]] = args[1]
            elif address == "/VMC/Ext/T":
                frame["t"] = args[0]
        frames.append(frame)
    sock.close()
    return frames


def draw(frames: list[dict], out: str, shown: int = 4) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    picks = np.linspace(0, len(frames) - 1, shown).round().astype(int)
    fig, axes = plt.subplots(3, shown, figsize=(3.2 * shown, 9.2), gridspec_kw={"height_ratios": [3, 3, 1.2]})
    span = frames[-1]["at"] - frames[0]["at"]
    fig.suptitle(f"our VMC receiver: {len(frames)} bundles in {span:.1f} s, "
                 f"{len(frames[0]['bones'])} bones, {len(frames[0]['blends'])} blendshapes", fontsize=11)
    for col, k in enumerate(picks):
        P = world_positions(frames[k]["bones"])
        for row, (axis, label) in enumerate(((0, "seen from behind (Unity x, y)"), (2, "from its right (Unity z, y)"))):
            ax = axes[row, col]
            for name, p in PARENT.items():
                if p is None or name not in P or p not in P:
                    continue
                side = "tab:red" if name.startswith("Left") else "tab:blue" if name.startswith("Right") else "k"
                ax.plot([P[p][axis], P[name][axis]], [P[p][1], P[name][1]], color=side, lw=1.6)
            ax.set_aspect("equal")
            ax.set_xlim(-1.0, 1.0)
            ax.set_ylim(-0.1, 1.9)
            ax.set_xticks([])
            ax.set_yticks([])
            if row == 0:
                ax.set_title(f"frame {k}, T = {frames[k]['t']:.2f} s", fontsize=9)
            if col == 0:
                ax.set_ylabel(label, fontsize=9)
        ax = axes[2, col]
        names = [n for n in ("A", "I", "U", "E", "O", "Blink_L", "Blink_R") if n in frames[k]["blends"]]
        ax.bar(names, [frames[k]["blends"][n] for n in names], color="tab:green")
        ax.set_ylim(0, 1)
        ax.tick_params(labelsize=7)
    fig.text(0.5, 0.005, "left side red, right side blue (the avatar's own sides: its left at -x in Unity)",
             ha="center", fontsize=9)
    fig.tight_layout(rect=(0, 0.02, 1, 0.97))
    fig.savefig(out, dpi=90)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--port", type=int, default=39539)
    p.add_argument("--seconds", type=float, default=60.0)
    p.add_argument("--out", default="vmc_view.png")
    args = p.parse_args()
    frames = listen(args.port, args.seconds)
    if not frames:
        print("no VMC bundle arrived")
        return 1
    draw(frames, args.out)
    print(f"{len(frames)} bundles; wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
