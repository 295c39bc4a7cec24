#!/usr/bin/python3
"""Design check on the synthetic validation sets (never on DiLiGenT): the
network's normal alone against the least-squares refit on the samples that
agree with it (solver/learned_kernel.cc, FinishFit with refine), per light
count bucket, beside plain least squares.

  scripts/train/evaluate_refit.py build/train/settransformer.pt build/train/val_77_30000.obs
"""
import os
import sys

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import numpy as np  # noqa: E402
import torch  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import normal_net as nn_lib  # noqa: E402
import train_normal_net as train  # noqa: E402

ALBEDO_BAND, MIN_SHADING, ROUNDS, MAX_REFINE_DEG, MIN_SAMPLE = 0.25, 0.05, 2, 8.0, 0.002


def agreeing(L, b, n):
    s = L @ n
    ok = s > MIN_SHADING
    if not ok.any():
        return np.zeros(len(b), bool)
    med = np.median(b[ok] / s[ok])
    return ok & (np.abs(b / np.where(ok, s, 1) - med) <= ALBEDO_BAND * abs(med))


def refit(L, b, n0):
    n = n0.copy()
    w = agreeing(L, b, n)
    for _ in range(ROUNDS):
        if w.sum() < 3:
            break
        G = L[w].T @ L[w]
        ev = np.linalg.eigvalsh(G)
        if ev[0] <= 0 or np.sqrt(ev[-1] / ev[0]) > 100:
            break
        x = np.linalg.solve(G, L[w].T @ b[w])
        if np.linalg.norm(x) == 0:
            break
        r = x / np.linalg.norm(x)
        if r @ n0 < np.cos(np.radians(MAX_REFINE_DEG)):
            break
        n = r
        w = agreeing(L, b, n)
    return n


def main():
    model_path, val_path = sys.argv[1], sys.argv[2]
    saved = torch.load(model_path)
    design = "settransformer" if "settransformer" in model_path else "deepset2"
    model, _ = train.make_model(design)
    model.load_state_dict(saved["state"])
    val = nn_lib.read_observations(val_path)
    idx = np.arange(min(len(val["normal"]), 20000))
    pred, _ = train.predict(model, val, idx)
    off = val["offset"]
    refined = np.zeros_like(pred)
    for row, s in enumerate(idx):
        L = val["light_dir"][off[s]:off[s + 1]].astype(np.float64)
        b = val["value"][off[s]:off[s + 1]].astype(np.float64)
        used = b > MIN_SAMPLE  # the solver's used samples (dark ones are tokens, not samples)
        refined[row] = refit(L[used], b[used], pred[row].astype(np.float64)) if used.sum() >= 3 else pred[row]
    truth = val["normal"][idx]
    lsq = nn_lib.least_squares_normals(val, idx)
    counts = (off[1:] - off[:-1])[idx]
    errs = {"lsq": nn_lib.angular_error_deg(lsq, truth), "net": nn_lib.angular_error_deg(pred, truth),
            "net+refit": nn_lib.angular_error_deg(refined, truth)}
    flags = val["material_flags"][idx]
    groups = [("all", np.ones(len(idx), bool)), ("lambertian only", flags == 0),
              ("specular", (flags & 1) != 0), ("sheen", (flags & 8) != 0), ("cast shadow", (flags & 32) != 0)]
    for lo, hi, name in train.BUCKETS:
        groups.append((f"{name} lights", (counts >= lo) & (counts <= hi)))
    print(f"{'sets':>24} {'n':>6} " + " ".join(f"{k:>10}" for k in errs))
    for name, sel in groups:
        print(f"{name:>24} {sel.sum():6d} " + " ".join(f"{e[sel].mean():10.3f}" for e in errs.values()))


if __name__ == "__main__":
    main()
