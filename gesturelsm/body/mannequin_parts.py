"""The mannequin's body parts, each a closed surface with skinning weights (left side mirrored to the right).

All shapes are designed around the rest skeleton (`mannequin_skeleton.py`): cross-section profiles are
key rows (position along the part, half-extents...) interpolated with monotone cubics. Dimensions are
metres for an adult of ~1.8 m; they were tuned by eye on rendered previews.
Skinning: a segment between joint a and its child b follows a; around b the weight passes smoothly from
a to b over a few centimetres (see `chain_weights`).
"""
from __future__ import annotations

import numpy as np

from ..motion.skeleton import JOINT_INDEX as JI
from ..motion.skeleton import MIRROR_PERM
from .mannequin_mesh import Part, chain_weights, join_rings, merge_parts, profile, smoothstep, sweep
from .mannequin_skeleton import KNUCKLE_Y, KNUCKLE_Z, RestSkeleton
from .proportions import FINGERS

X, Y, Z = np.eye(3)


def frame(d: np.ndarray, u_ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cross-section axes (u, v) for sweep direction d: u closest to u_ref, u x v = d."""
    d = d / np.linalg.norm(d)
    u = u_ref - (u_ref @ d) * d
    u /= np.linalg.norm(u)
    return u, np.cross(d, u)


def mirror_part(p: Part, name: str) -> Part:
    """Left part -> right part: x -> -x, faces re-wound, joint columns swapped left/right."""
    m = np.array([-1.0, 1.0, 1.0])
    rings = {k.replace("left_", "right_"): v for k, v in p.rings.items()}
    return Part(name, p.vertices * m, p.faces[:, ::-1].copy(), p.axis_points * m, p.s.copy(),
                p.weights[:, list(MIRROR_PERM)], p.girth, rings)


def onehot(n: int, joint: int) -> np.ndarray:
    W = np.zeros((n, 55))
    W[:, joint] = 1.0
    return W


# ---- trunk: torso, neck and both legs as one surface --------------------------------------------------------
# hh = height above the hip joints; half-width, front, back (from the axis), axis z, superellipse power
TRUNK_KEYS = [
    (-0.085, 0.150, 0.075, 0.090, 0.000, 2.4), (-0.040, 0.165, 0.086, 0.104, 0.000, 2.4),
    (0.000, 0.171, 0.090, 0.108, 0.000, 2.4), (0.050, 0.167, 0.094, 0.108, 0.000, 2.4),
    (0.100, 0.155, 0.097, 0.098, 0.000, 2.4), (0.170, 0.139, 0.100, 0.090, 0.000, 2.3),
    (0.240, 0.146, 0.107, 0.094, 0.000, 2.3), (0.310, 0.158, 0.118, 0.101, 0.000, 2.4),
    (0.380, 0.165, 0.125, 0.106, 0.000, 2.5), (0.450, 0.167, 0.118, 0.110, 0.000, 2.6),
    (0.500, 0.169, 0.104, 0.106, 0.000, 2.7), (0.545, 0.167, 0.088, 0.094, 0.000, 2.8),
    (0.575, 0.147, 0.070, 0.082, -0.005, 2.6), (0.600, 0.112, 0.060, 0.072, -0.012, 2.4),
    (0.625, 0.074, 0.054, 0.060, -0.018, 2.1), (0.650, 0.058, 0.050, 0.050, -0.020, 2.0),
    (0.672, 0.052, 0.046, 0.046, -0.018, 2.0), (0.695, 0.044, 0.040, 0.040, -0.012, 2.0),
]
CROTCH_H, CROTCH_POINTS, CROTCH_SAG = -0.085, 5, 0.012
TORSO_N = 32                                  # vertices per torso ring (multiple of 4)
# d = distance below the hip joint; outer, inner (x), front, back half-extents
LEG_KEYS = [
    (0.10, 0.080, 0.068, 0.074, 0.082), (0.15, 0.079, 0.067, 0.074, 0.076), (0.28, 0.066, 0.060, 0.064, 0.062),
    (0.38, 0.057, 0.053, 0.056, 0.054), (0.43, 0.054, 0.051, 0.056, 0.051), (0.48, 0.053, 0.051, 0.051, 0.060),
    (0.55, 0.054, 0.052, 0.048, 0.067), (0.65, 0.046, 0.044, 0.041, 0.050), (0.78, 0.035, 0.034, 0.034, 0.037),
    (0.86, 0.034, 0.033, 0.035, 0.036), (0.90, 0.031, 0.030, 0.032, 0.033),
]


def _leg_section(hip: np.ndarray, hh: np.ndarray) -> tuple[np.ndarray, ...]:
    """Left thigh cross-section at heights hh: centre x, z and semi-axes (a along x, c along z)."""
    leg = profile(LEG_KEYS, np.clip(-hh, LEG_KEYS[0][0], None))           # (n, 4): out, in, front, back
    a, c = (leg[:, 0] + leg[:, 1]) / 2, (leg[:, 2] + leg[:, 3]) / 2
    return hip[0] + (leg[:, 0] - leg[:, 1]) / 2, hip[2] + (leg[:, 2] - leg[:, 3]) / 2, a, c


def _hug_thighs(p: Part, hip: np.ndarray) -> None:
    """Below the hip joints, morph the torso's cross-section into the union of the two thighs' sections,
    so the legs grow out of the hips without a seam."""
    rel = p.vertices - p.axis_points                     # horizontal offsets from the axis
    hh = p.vertices[:, 1] - hip[1]
    b = smoothstep((0.05 - hh) / 0.13) * (np.linalg.norm(rel, axis=1) > 1e-9)
    dirs = rel / np.maximum(np.linalg.norm(rel, axis=1, keepdims=True), 1e-12)
    cx, cz, a, c = _leg_section(hip, hh)
    exits = []
    for sx in (1.0, -1.0):  # 2D ray from the axis to the far side of each thigh ellipse
        dx, dz = dirs[:, 0] / a, dirs[:, 2] / c
        ox, oz = -sx * cx / a, (p.axis_points[:, 2] - cz) / c
        A, B, C = np.maximum(dx * dx + dz * dz, 1e-12), 2 * (dx * ox + dz * oz), ox * ox + oz * oz - 1
        disc = B * B - 4 * A * C
        exits.append(np.where(disc > 0, (-B + np.sqrt(np.clip(disc, 0, None))) / (2 * A), 0.0))
    target = np.maximum(np.maximum(*exits), 0.025)
    r = np.linalg.norm(rel, axis=1)
    p.vertices = p.axis_points + dirs * ((1 - b) * r + b * target)[:, None]


def _torso(sk: RestSkeleton) -> tuple[Part, dict[str, float]]:
    J = sk.joints
    hip = J[JI["left_hip"]]
    jh = {n: float(J[JI[n], 1] - hip[1]) for n in ("pelvis", "spine1", "spine2", "spine3", "neck", "head")}
    h = np.concatenate([np.linspace(CROTCH_H, 0.5, 21), np.linspace(0.515, 0.695, 11), [0.0], list(jh.values())])
    h = np.unique(h)                                                         # stations incl. every joint
    pr = profile(TRUNK_KEYS, h)                                             # (K, 5)
    centres = np.stack([np.zeros_like(h), hip[1] + h, pr[:, 3]], 1)
    radii = np.stack([pr[:, 0], pr[:, 0], pr[:, 1], pr[:, 2]], 1)           # +x, -x, +z, -z
    p = sweep("torso", centres, X, Z, radii, n=TORSO_N, power=pr[:, 4], cap_start=-1, cap_end=0.015, s=h)
    p.faces = p.faces[:, ::-1].copy()   # u = x, v = z gives x cross z = -y: flip for an upward sweep
    _hug_thighs(p, hip)
    for name, hh in jh.items():
        p.rings[name] = p.rings[f"station{int(np.argmin(np.abs(h - hh)))}"]
    ring0 = p.rings[f"station{int(np.argmin(np.abs(h)))}"]
    p.rings["left_hip"] = ring0[p.vertices[ring0, 0] > 1e-6]
    p.rings["right_hip"] = ring0[p.vertices[ring0, 0] < -1e-6]
    return p, jh


def _torso_weights(v: np.ndarray, hip: np.ndarray, jh: dict[str, float]) -> np.ndarray:
    hv = v[:, 1] - hip[1]
    W = chain_weights(hv, [JI[n] for n in ("pelvis", "spine1", "spine2", "spine3", "neck", "head")],
                      [(jh["spine1"], 0.08, 0.08), (jh["spine2"], 0.06, 0.06), (jh["spine3"], 0.05, 0.05),
                       (jh["neck"], 0.03, 0.02), (jh["head"], 0.02, 0.015)])
    ax = np.abs(v[:, 0])
    for side, sgn in (("left", 1.0), ("right", -1.0)):
        on_side = (np.sign(v[:, 0]) == sgn).astype(float)
        # hips, buttocks and groin follow the thigh
        w_leg = on_side * smoothstep((ax - 0.03) / 0.09) * smoothstep((0.02 - hv) / 0.10)
        W = W * (1 - w_leg[:, None]) + w_leg[:, None] * onehot(len(v), JI[f"{side}_hip"])
        # shoulder girdle follows the collar bone, its outer corner partly the upper arm
        w_col = on_side * smoothstep((ax - 0.07) / 0.07) * smoothstep((hv - 0.42) / 0.10)
        W = W * (1 - w_col[:, None]) + w_col[:, None] * onehot(len(v), JI[f"{side}_collar"])
        w_arm = on_side * smoothstep((ax - 0.13) / 0.05) * smoothstep((hv - 0.47) / 0.07) * 0.5
        W = W * (1 - w_arm[:, None]) + w_arm[:, None] * onehot(len(v), JI[f"{side}_shoulder"])
    return W


def _leg(sk: RestSkeleton, branch_pts: np.ndarray) -> Part:
    """Left leg below the crotch; its rings use the angles of the branch loop it continues."""
    J = sk.joints
    hip, knee, ankle = J[JI["left_hip"]], J[JI["left_knee"]], J[JI["left_ankle"]]
    dk, da = hip[1] - knee[1], hip[1] - ankle[1]
    d0 = -CROTCH_H + 0.03
    d = np.unique(np.concatenate([np.linspace(d0, 0.90, 20), [dk, da]]))
    pr = profile(LEG_KEYS, d)
    theta = np.unwrap(np.arctan2(branch_pts[:, 2] - hip[2], branch_pts[:, 0] - hip[0]))
    assert np.all(np.diff(theta) > 0), "branch loop must wind around the thigh"
    p = sweep("left_leg", hip - d[:, None] * Y, X, Z, pr[:, :4], n=len(theta), cap_start=-1, cap_end=0.03,
              s=d, theta=theta)
    p.rings["left_knee"] = p.rings[f"station{int(np.argmin(np.abs(d - dk)))}"]
    p.rings["left_ankle"] = p.rings[f"station{int(np.argmin(np.abs(d - da)))}"]
    p.weights = chain_weights(p.s, [JI["pelvis"], JI["left_hip"], JI["left_knee"], JI["left_ankle"]],
                              [(0.0, 0.07, 0.05), (dk, 0.04, 0.04), (da, 0.05, 0.02)])
    return p


def trunk(sk: RestSkeleton) -> Part:
    """Torso + neck + legs: the torso's open bottom ring is split by a crotch seam into two loops, each
    continued by a leg (a "pants" topology), so the surface is closed and seamless."""
    hip = sk.joints[JI["left_hip"]]
    torso, jh = _torso(sk)
    ring0 = torso.rings["first"]                       # TORSO_N vertices, i = 0 at +x, i = N/4 at the front
    q = TORSO_N // 4
    front, back = torso.vertices[ring0[q]], torso.vertices[ring0[3 * q]]
    t = np.arange(1, CROTCH_POINTS + 1) / (CROTCH_POINTS + 1)
    crotch = front + t[:, None] * (back - front) - (CROTCH_SAG * np.sin(np.pi * t))[:, None] * Y
    nt = len(torso.vertices)
    crotch_ids = nt + np.arange(CROTCH_POINTS)
    left_loop = np.concatenate([ring0[: q + 1], crotch_ids, ring0[3 * q:]])
    right_loop = np.concatenate([ring0[[(2 * q - i) % TORSO_N for i in range(q + 1)]], crotch_ids,
                                 ring0[[(2 * q - i) % TORSO_N for i in range(3 * q, TORSO_N)]]])
    verts = np.concatenate([torso.vertices, crotch])
    left = _leg(sk, verts[left_loop])
    right = mirror_part(left, "right_leg")
    base_l, base_r = nt + CROTCH_POINTS, nt + CROTCH_POINTS + len(left.vertices)
    band_l = join_rings(left_loop, left.rings["first"] + base_l)
    band_r = join_rings(right_loop, right.rings["first"] + base_r)[:, ::-1]
    crotch_part = Part("crotch", crotch, np.zeros((0, 3), np.int64), crotch.copy(), crotch[:, 1])  # no girth
    torso.vertices = verts[:nt]
    for part in (torso, crotch_part):
        part.weights = _torso_weights(part.vertices, hip, jh)
    out = merge_parts("trunk", [torso, crotch_part, left, right], [band_l, band_r])
    out.rings = {k.split("/", 1)[1]: v for k, v in out.rings.items()
                 if k.split("/", 1)[1] in ("pelvis", "spine1", "spine2", "spine3", "neck", "head", "left_hip",
                                           "right_hip", "left_knee", "left_ankle", "right_knee", "right_ankle")}
    out.girth = True
    return out


# z ahead of the ankle; outer, inner half-widths, height of the top above the sole
FOOT_KEYS = [
    (-0.060, 0.026, 0.026, 0.055), (-0.035, 0.031, 0.031, 0.075), (0.000, 0.035, 0.035, 0.090),
    (0.050, 0.040, 0.041, 0.072), (0.100, 0.045, 0.047, 0.052), (0.150, 0.043, 0.045, 0.042),
    (0.200, 0.037, 0.039, 0.034), (0.230, 0.030, 0.031, 0.028),
]


def foot(sk: RestSkeleton) -> Part:
    J = sk.joints
    ankle, ball = J[JI["left_ankle"]], J[JI["left_foot"]]
    tip_z = sk.toe_tips["left"][2] - ankle[2]
    zb = ball[2] - ankle[2]
    z = np.unique(np.concatenate([np.linspace(-0.06, tip_z - 0.014, 15), [0.0, zb]]))
    pr = profile(FOOT_KEYS, z)
    hgt = pr[:, 2]
    centres = np.stack([np.full_like(z, ankle[0]), sk.sole_y + hgt / 2, ankle[2] + z], 1)
    radii = np.stack([pr[:, 0], pr[:, 1], hgt / 2, hgt / 2], 1)  # +x out, -x in, up, down
    p = sweep("left_foot", centres, X, Y, radii, n=16, power=3.2, cap_start=0.012, cap_end=0.014, s=z)
    p.rings["left_foot"] = p.rings[f"station{int(np.argmin(np.abs(z - zb)))}"]
    p.weights = chain_weights(p.s, [JI["left_ankle"], JI["left_foot"]], [(zb, 0.02, 0.015)])
    return p


# ---- arms and hands ---------------------------------------------------------------------------------------
# d = distance along the arm from the shoulder joint; up, down, front, back half-extents
ARM_KEYS = [
    (-0.118, 0.032, 0.034, 0.036, 0.040), (-0.06, 0.044, 0.040, 0.046, 0.050), (0.0, 0.052, 0.047, 0.052, 0.052),
    (0.06, 0.048, 0.046, 0.050, 0.050), (0.15, 0.043, 0.042, 0.045, 0.045), (0.26, 0.039, 0.037, 0.040, 0.040),
    (0.306, 0.036, 0.035, 0.037, 0.040), (0.36, 0.037, 0.036, 0.043, 0.041), (0.45, 0.031, 0.029, 0.036, 0.034),
    (0.54, 0.021, 0.020, 0.029, 0.028), (0.561, 0.0185, 0.0185, 0.029, 0.028),
]


# d = distance from the wrist along x; up (back of the hand), down (palm), thumb side, little-finger side,
# about the palm's centre line (KNUCKLE_Y below the wrist, midway between index and little finger)
PALM_KEYS = [
    (0.018, 0.0175, 0.0190, 0.033, 0.032), (0.035, 0.0155, 0.0185, 0.038, 0.036),
    (0.055, 0.0135, 0.0165, 0.040, 0.038), (0.075, 0.0120, 0.0135, 0.041, 0.040), (0.088, 0.0110, 0.0120, 0.040, 0.039),
]
FINGER_RADIUS = {"index": 0.0098, "middle": 0.0102, "ring": 0.0094, "pinky": 0.0082}


def arm(sk: RestSkeleton) -> Part:
    """Collar to knuckles in one tube: upper arm, forearm and the palm (so the wrist has no seam)."""
    J = sk.joints
    col, sh, el, wr = (J[JI[f"left_{n}"]] for n in ("collar", "shoulder", "elbow", "wrist"))
    dc, de, dw = col[0] - sh[0], el[0] - sh[0], wr[0] - sh[0]
    zc = (KNUCKLE_Z["index"] + KNUCKLE_Z["pinky"]) / 2
    palm = [(dw + k[0], k[1] + KNUCKLE_Y, k[2] - KNUCKLE_Y, k[3] + zc, k[4] - zc) for k in PALM_KEYS]
    end = palm[-1][0]
    d = np.unique(np.concatenate([np.linspace(dc, dw, 28), np.linspace(dw, end, 7)[1:], [0.0, de]]))
    pr = profile(ARM_KEYS + palm, d)
    power = profile([(dc, 2.0), (dw - 0.01, 2.0), (dw + 0.03, 2.3), (end, 2.3)], d)[:, 0]
    centres = np.stack([sh[0] + d, np.full_like(d, sh[1]), np.full_like(d, sh[2])], 1)
    p = sweep("left_arm", centres, Y, Z, pr[:, :4], n=20, power=power, cap_start=0.025, cap_end=0.012, s=d)
    for name, dd in (("left_collar", dc), ("left_shoulder", 0.0), ("left_elbow", de), ("left_wrist", dw)):
        p.rings[name] = p.rings[f"station{int(np.argmin(np.abs(d - dd)))}"]
    p.weights = chain_weights(p.s, [JI["left_collar"], JI["left_shoulder"], JI["left_elbow"], JI["left_wrist"]],
                              [(0.0, 0.06, 0.05), (de, 0.035, 0.035), (dw, 0.05, 0.012)])
    p.girth = True
    return p


def finger(sk: RestSkeleton, f: str) -> Part:
    J = sk.joints
    j1, j2, j3 = (J[JI[f"left_{f}{k}"]] for k in (1, 2, 3))
    tip = sk.finger_tips[f"left_{f}"]
    d = (tip - j1) / np.linalg.norm(tip - j1)
    L1, L2, L3 = np.linalg.norm(j2 - j1), np.linalg.norm(j3 - j2), np.linalg.norm(tip - j3)
    r0 = FINGER_RADIUS[f] if f in FINGER_RADIUS else 0.011
    keys = [(-0.02, r0 * 1.05), (0.0, r0), (L1, r0 * 0.9), (L1 + L2, r0 * 0.8), (L1 + L2 + L3, r0 * 0.72)]
    s = np.unique(np.concatenate([np.linspace(-0.02, L1 + L2 + L3 - 0.006, 8), [0.0, L1, L1 + L2]]))
    r = profile(keys, s)[:, 0]
    u, v = frame(d, Y)
    radii = np.stack([r * 0.86, r * 0.9, r, r], 1)
    p = sweep(f"left_{f}", j1 + s[:, None] * d, u, v, radii, n=8, cap_start=0.004, cap_end=r[-1] * 0.9 + 0.003, s=s)
    for k, sk_ in zip((1, 2, 3), (0.0, L1, L1 + L2)):
        p.rings[f"left_{f}{k}"] = p.rings[f"station{int(np.argmin(np.abs(s - sk_)))}"]
    p.weights = chain_weights(p.s, [JI["left_wrist"], JI[f"left_{f}1"], JI[f"left_{f}2"], JI[f"left_{f}3"]],
                              [(0.0, 0.007, 0.004), (L1, 0.005, 0.004), (L1 + L2, 0.004, 0.003)])
    return p


def thumb(sk: RestSkeleton) -> Part:
    J = sk.joints
    t1, t2, t3 = (J[JI[f"left_thumb{k}"]] for k in (1, 2, 3))
    tip = sk.finger_tips["left_thumb"]
    d = (tip - t1) / np.linalg.norm(tip - t1)
    L1, L2, L3 = np.linalg.norm(t2 - t1), np.linalg.norm(t3 - t2), np.linalg.norm(tip - t3)
    keys = [(-0.012, 0.010), (0.0, 0.0115), (L1 * 0.5, 0.0128), (L1, 0.0118), (L1 + L2, 0.0103),
            (L1 + L2 + L3, 0.0092)]
    s = np.unique(np.concatenate([np.linspace(-0.012, L1 + L2 + L3 - 0.008, 9), [0.0, L1, L1 + L2]]))
    r = profile(keys, s)[:, 0]
    u, v = frame(d, np.array([0.0, 1.0, -0.6]))          # nail turned towards the front
    radii = np.stack([r * 0.85, r * 0.95, r, r], 1)
    knots = np.array([-0.012, 0.0, L1, L1 + L2, L1 + L2 + L3])
    pts = np.stack([t1 - 0.012 * d, t1, t2, t3, tip])
    centres = np.stack([np.interp(s, knots, pts[:, i]) for i in range(3)], 1)  # through the joints exactly
    p = sweep("left_thumb", centres, u, v, radii, n=10, cap_start=0.008, cap_end=r[-1] + 0.002, s=s)
    for k, sk_ in zip((1, 2, 3), (0.0, L1, L1 + L2)):
        p.rings[f"left_thumb{k}"] = p.rings[f"station{int(np.argmin(np.abs(s - sk_)))}"]
    p.weights = chain_weights(p.s, [JI["left_wrist"], JI["left_thumb1"], JI["left_thumb2"], JI["left_thumb3"]],
                              [(0.0, 0.01, 0.01), (L1, 0.006, 0.005), (L1 + L2, 0.004, 0.003)])
    return p


def left_side(sk: RestSkeleton) -> list[Part]:
    return [foot(sk), arm(sk), thumb(sk)] + [finger(sk, f) for f in FINGERS]


def both_sides(sk: RestSkeleton) -> list[Part]:
    left = left_side(sk)
    return left + [mirror_part(p, p.name.replace("left_", "right_")) for p in left]
