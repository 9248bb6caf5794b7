"""The paper's numbers (GestureLSM, ICCV 2025; BEAT2 speaker 2 test set, one A100), shown beside ours.
FGD is EMAGE's autoencoder FGD as printed in the paper's table (x 1e-1); AITS in seconds per clip."""
from __future__ import annotations

GROUND_TRUTH = {"bc": 0.703, "diversity": 11.97}

# Table 1 rows (FGD, BC, Div, face vertex MSE x 1e-7 or None, AITS s)
TABLE1 = {
    "EMAGE": (5.512, 0.772, 13.06, 7.680, 0.174),
    "SynTalker (diffusion)": (4.687, 0.736, 12.43, None, 2.942),
    "GestureLSM": (4.088, 0.714, 13.24, None, 0.039),
    "GestureLSM (+Face)": (4.247, 0.729, 13.76, 1.021, 0.042),
}

# Table 4e: GestureLSM by sampling steps -> (FGD, BC, Div, AITS)
STEPS = {1: (6.235, 0.647, 13.23, 0.015), 2: (4.988, 0.680, 13.39, 0.018), 4: (4.262, 0.704, 13.35, 0.026),
         8: (4.088, 0.714, 13.24, 0.039), 20: (4.040, 0.730, 13.49, 0.076)}

# Table 4c: generator type -> (FGD, Div, AITS); the paper does not state the baselines' step counts
MODEL_TYPE = {"ddim": (4.131, 13.06, 2.942), "rectified_flow": (4.724, 13.21, 0.074),
              "gesturelsm": (4.088, 13.24, 0.039)}

# Table 4b: time sampling -> (FGD, BC, Div)
TIME_SAMPLING = {"uniform": (5.051, 0.721, 13.56), "beta(2, 1.2)": (4.088, 0.714, 13.24)}


def paper_row(method: str, steps: int) -> dict | None:
    """The paper's numbers for one of our rows, when it has them."""
    if method == "gesturelsm" and steps in STEPS:
        f, bc, div, t = STEPS[steps]
        return {"fgd": f, "bc": bc, "diversity": div, "aits": t}
    if method in MODEL_TYPE and method != "gesturelsm" and steps == 20:
        # the paper does not state the baselines' steps; the reference code samples DDIM with 20
        f, div, t = MODEL_TYPE[method]
        return {"fgd": f, "diversity": div, "aits": t, "note": "steps not stated"}
    return None
