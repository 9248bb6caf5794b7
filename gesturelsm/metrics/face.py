"""Face error: expression-parameter MSE and, with a body model, face vertex MSE (the paper's "MSE").

- `expression_mse`: mean squared error of the 100 FLAME expression coefficients (unitless), frame-aligned.
- `face_vertex_mse`: the paper's metric (x 1e-7 in its table): both motions posed with only the jaw (joint 22)
  and expressions, body at rest and no translation, then the mean over frames, vertices and axes of the
  squared vertex difference (m^2). Meaningful with a real SMPL-X model (`--smplx`); the built-in mannequin's
  face only shows the jaw and three expression directions, so its number is reported but not comparable.
"""
from __future__ import annotations

import numpy as np

JAW = 22


def expression_mse(pred: np.ndarray, gt: np.ndarray) -> float:
    n = min(len(pred), len(gt))
    return float(((np.asarray(pred[:n], np.float64) - np.asarray(gt[:n], np.float64)) ** 2).mean())


def _face_only(poses: np.ndarray) -> np.ndarray:
    p = np.zeros_like(np.asarray(poses, np.float32))
    p[:, 3 * JAW:3 * JAW + 3] = poses[:, 3 * JAW:3 * JAW + 3]
    return p


def face_vertex_mse(body, pred, gt) -> float:
    """pred, gt: MotionSequence-like (poses (T, 165), expressions (T, E), betas). -> m^2."""
    n = min(len(pred.poses), len(gt.poses))
    zero = np.zeros((n, 3), np.float32)
    vp = body.forward(_face_only(pred.poses[:n]), zero, pred.expressions[:n], gt.betas).vertices
    vg = body.forward(_face_only(gt.poses[:n]), zero, gt.expressions[:n], gt.betas).vertices
    return float(((vp.astype(np.float64) - vg) ** 2).mean())
