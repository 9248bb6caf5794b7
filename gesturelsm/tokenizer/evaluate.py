"""Reconstruction quality of a region tokenizer on held-out motion (`gesturelsm eval-tokenizer`)."""
from __future__ import annotations

from typing import Any

import torch

from ..body import load_body_model
from ..body.fk import forward_kinematics
from ..data.split import split_features
from ..errors import CheckpointError
from ..motion.regions import REGIONS, TRANS_OFFSET
from ..motion.rotations import geodesic_angle, rot6d_to_matrix
from ..motion.skeleton import PARENTS
from ..motion.translation import velocity_to_trans
from .model import RVQVAE


def pad_to_multiple(x: torch.Tensor, m: int) -> tuple[torch.Tensor, int]:
    """(T, C) -> (T', C) with T' a multiple of m, repeating the last frame; returns original T."""
    T = x.shape[0]
    extra = (-T) % m
    if extra:
        x = torch.cat([x, x[-1:].expand(extra, -1)])
    return x, T


@torch.no_grad()
def reconstruct(model: RVQVAE, raw_region: torch.Tensor, num_layers: int | None = None) -> tuple[torch.Tensor,
                                                                                                 torch.Tensor]:
    """Raw region features (T, C) -> (reconstruction (T, C) raw, codes (T/4, L)) through all or k layers."""
    model.eval()
    x, T = pad_to_multiple(model.normalizer.normalize(raw_region), model.config.downsample)
    z = model.encode(x[None])
    q = model.quantize(z, num_layers)
    recon = model.decode(q.quantized.reshape(z.shape))[0, :T]
    return model.normalizer.denormalize(recon), q.codes


def rotation_errors_deg(region: str, gt: torch.Tensor, rec: torch.Tensor) -> torch.Tensor:
    """Per-frame, per-joint geodesic error in degrees between two (T, C) raw region feature arrays."""
    n = len(REGIONS[region].joints)
    Rg = rot6d_to_matrix(gt[:, :6 * n].reshape(-1, n, 6))
    Rr = rot6d_to_matrix(rec[:, :6 * n].reshape(-1, n, 6))
    return torch.rad2deg(geodesic_angle(Rg, Rr))  # (T, n)


def reconstruction_error(model: RVQVAE, heldout: list[torch.Tensor], num_layers: int | None = None) -> float:
    """Mean joint rotation error (degrees) over held-out sequences of full 433-d features."""
    cols = list(REGIONS[model.region].columns)
    errs = [rotation_errors_deg(model.region, h[:, cols], reconstruct(model, h[:, cols], num_layers)[0]).reshape(-1)
            for h in heldout]
    return torch.cat(errs).mean().item()



# ---- full report: rotation / position error, jitter, codebook usage, per number of RVQ layers ----------

def _joint_positions(feats: torch.Tensor, rest_joints: torch.Tensor) -> torch.Tensor:
    """(T, 433) raw features -> (T, 55, 3) joint positions (m) by forward kinematics on the given skeleton."""
    T = feats.shape[0]
    rot = rot6d_to_matrix(feats[:, :330].reshape(T, 55, 6))
    joints, _ = forward_kinematics(rot, rest_joints, PARENTS)
    return joints + velocity_to_trans(feats[:, TRANS_OFFSET:TRANS_OFFSET + 3])[:, None]


def jitter(pos: torch.Tensor, fps: int = 30) -> float:
    """Mean magnitude of joint acceleration (m/s^2) of (T, J, 3) positions."""
    acc = pos[2:] - 2 * pos[1:-1] + pos[:-2]
    return (acc.norm(dim=-1) * fps * fps).mean().item()


@torch.no_grad()
def evaluate_region(model: RVQVAE, heldout: list[torch.Tensor], rest_joints: torch.Tensor) -> dict:
    region = REGIONS[model.region]
    cols = list(region.columns)
    joints = list(region.joints)
    L = model.config.num_quantizers
    rows = []
    usage = None
    for k in range(1, L + 1):
        rot, pos, jit_rec, jit_gt, extra = [], [], [], [], []
        codes_all = []
        for h in heldout:
            rec, codes = reconstruct(model, h[:, cols], k)
            codes_all.append(codes)
            rot.append(rotation_errors_deg(model.region, h[:, cols], rec).reshape(-1))
            full = h.clone()
            full[:, cols] = rec
            p_gt, p_rec = _joint_positions(h, rest_joints), _joint_positions(full, rest_joints)
            pos.append((p_gt[:, joints] - p_rec[:, joints]).norm(dim=-1).reshape(-1) * 1000)
            jit_rec.append(jitter(p_rec[:, joints]))
            jit_gt.append(jitter(p_gt[:, joints]))
            if region.expressions:
                extra.append((h[:, -100:] - rec[:, -100:]).abs().mean().item())
            if region.trans:
                extra.append((p_gt[:, 0] - p_rec[:, 0]).norm(dim=-1).mean().item() * 1000)
        row = {"layers": k, "rot_deg": torch.cat(rot).mean().item(), "pos_mm": torch.cat(pos).mean().item(),
               "jitter": sum(jit_rec) / len(jit_rec), "jitter_gt": sum(jit_gt) / len(jit_gt)}
        if region.expressions:
            row["expr_l1"] = sum(extra) / len(extra)
        if region.trans:
            row["root_mm"] = sum(extra) / len(extra)
        rows.append(row)
        if k == L:
            c = torch.cat(codes_all)
            usage = [sum((torch.bincount(c[:, i, g], minlength=model.config.codebook_size) > 0).float().mean().item()
                         for g in range(c.shape[2])) / c.shape[2] for i in range(L)]
    return {"region": model.region, "full": rows[-1], "by_layers": rows, "codebook_usage": usage,
            "codebook_size": model.config.codebook_size}


def evaluate_folder(data_root, ckpt_dir, train_fraction: float = 0.8, body_model=None) -> dict:
    from pathlib import Path

    split = split_features(data_root, train_fraction)
    rest = torch.as_tensor(load_body_model(body_model).rest_joints(), dtype=torch.float32)
    out: dict[str, Any] = {"data": split.policy, "heldout_frames": sum(h.shape[0] for h in split.heldout),
                           "regions": {}}
    for path in sorted(Path(ckpt_dir).glob("*.safetensors")):
        model = RVQVAE.load(path)
        if model.region in REGIONS:
            out["regions"][model.region] = evaluate_region(model, split.heldout, rest)
    if not out["regions"]:
        raise CheckpointError(f"no tokenizer checkpoints (<region>.safetensors) in {ckpt_dir}")
    return out


def format_report(rep: dict) -> str:
    lines = [f"Held-out reconstruction ({rep['data']}; {rep['heldout_frames']} frames)", "",
             "| region | rot err (deg) | pos err (mm) | jitter rec / GT (m/s^2) | other | codebook usage per layer |",
             "|---|---|---|---|---|---|"]
    for name, r in rep["regions"].items():
        f = r["full"]
        other = ((f"expr L1 {f['expr_l1']:.3f}" if "expr_l1" in f else "")
                 + (f"root {f['root_mm']:.1f} mm" if "root_mm" in f else ""))
        use = " ".join(f"{u:.2f}" for u in r["codebook_usage"])
        lines.append(f"| {name} | {f['rot_deg']:.2f} | {f['pos_mm']:.1f} | {f['jitter']:.2f} / {f['jitter_gt']:.2f} | "
                     f"{other or '-'} | {use} (of {r['codebook_size']}) |")
    lines += ["", "Rotation error (deg) using only the first k RVQ layers:", ""]
    L = max(len(r["by_layers"]) for r in rep["regions"].values())
    lines.append("| region | " + " | ".join(f"k={k}" for k in range(1, L + 1)) + " |")
    lines.append("|---" * (L + 1) + "|")
    for name, r in rep["regions"].items():
        lines.append(f"| {name} | " + " | ".join(f"{row['rot_deg']:.2f}" for row in r["by_layers"]) + " |")
    return "\n".join(lines)
