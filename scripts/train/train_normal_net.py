#!/usr/bin/python3
"""Trains the learned photometric solver's network (issue #33) from nothing
but the project's own renders, and writes what the C++ solver embeds.

  scripts/train/setup.sh                 # Debian's python3-torch, numpy, OpenBLAS (once)
  ninja -C build scanbench               # the renderer (a Release build of the project)
  scripts/train/train_normal_net.py      # renders, trains both designs, keeps the better

Steps:
  1. render    `scanbench training-set` writes the training and validation sets
               (fixed seeds; app/sim/observation_sets.cc)
  2. train     each design of normal_net.py for a fixed number of steps, from a
               fixed torch seed, on 2 CPU threads
  3. validate  on the held-out synthetic sets only (never on DiLiGenT: see
               docs/solver.md, "Learned normals"), per light-count bucket,
               against least squares on the same sets
  4. write     data/models/normal_net.bin (the kept design), normal_net.json
               (the recipe, the validation figures, the sha256) and
               tests/solver/data/normal_net_vectors.txt (inputs and the PyTorch
               outputs the C++ forward pass must match within 1e-5)
"""

import argparse
import hashlib
import json
import math
import os
import subprocess
import sys
import time

# One BLAS thread per training process: the designs train side by side, one
# per core (OpenBLAS's own threads on top of torch's would oversubscribe them).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import multiprocessing  # noqa: E402

import numpy as np  # noqa: E402
import torch  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import normal_net as nn_lib  # noqa: E402

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))

BUCKETS = [(3, 8, "3-8"), (9, 12, "9-12"), (13, 24, "13-24"), (25, 48, "25-48"), (49, 256, "49+")]


def render(scanbench, path, seed, sets, threads):
    if not os.path.exists(scanbench):
        sys.exit(f"render: {scanbench} does not exist: build it first "
                 "(cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release && ninja -C build scanbench)")
    if os.path.exists(path):
        print(f"render: {path} exists, kept")
        return
    cmd = [scanbench, "training-set", path, "--seed", str(seed), "--sets", str(sets), "--threads", str(threads)]
    print("render:", " ".join(cmd), flush=True)
    subprocess.run(cmd, check=True)


def augment(ld, normal, rng):
    """A random turn about the view axis and a random mirror: the network should
    not care where azimuth 0 is."""
    b = ld.shape[0]
    angle = rng.uniform(0, 2 * math.pi, size=b).astype(np.float32)
    c, s = np.cos(angle), np.sin(angle)
    flip = np.where(rng.uniform(size=b) < 0.5, -1.0, 1.0).astype(np.float32)
    def turn(v):
        x, y, z = v[..., 0], v[..., 1] * flip.reshape((-1,) + (1,) * (v.ndim - 2)), v[..., 2]
        cc = c.reshape((-1,) + (1,) * (v.ndim - 2))
        ss = s.reshape((-1,) + (1,) * (v.ndim - 2))
        return np.stack([cc * x - ss * y, ss * x + cc * y, z], axis=-1)
    return turn(ld).astype(np.float32), turn(normal).astype(np.float32)


def drop_tokens(mask, rng):
    """Leaves out up to a third of a set's lights in a third of the sets (down to
    6): shadow masks and clipped samples shrink real sets the same way."""
    counts = mask.sum(axis=1)
    out = mask.copy()
    for row in np.nonzero(rng.uniform(size=mask.shape[0]) < 0.33)[0]:
        n = counts[row]
        if n <= 6:
            continue
        drop = rng.integers(0, max(1, min(n - 6, n // 3)) + 1)
        out[row, rng.choice(n, size=drop, replace=False)] = False
    return out


def vmf_nll(cos, log_kappa):
    """-log of the von Mises-Fisher density on the sphere at cos(angle), per set."""
    kappa = torch.exp(log_kappa)
    # log C(kappa) = log kappa - log 4pi - log sinh kappa; log sinh k = k + log(1 - e^-2k) - log 2.
    log_sinh = kappa + torch.log1p(-torch.exp(-2 * kappa).clamp(max=1 - 1e-7)) - math.log(2.0)
    return -(log_kappa - math.log(4 * math.pi) - log_sinh + kappa * cos)


def make_model(design):
    if design == "deepset2":
        return nn_lib.DeepSetNet(width=96, head=128), {"width": 96, "head": 128}
    if design == "settransformer":
        return nn_lib.SetTransformerNet(width=64, heads=4, blocks=2, ffn=128, head=128), {
            "width": 64, "heads": 4, "blocks": 2, "ffn": 128, "head": 128}
    raise ValueError(design)


def batches_by_size(obs, batch_size, rng):
    """Training batches of sets of similar size (sorted by light count, chunked,
    the chunks shuffled), so padding stays small."""
    counts = obs["offset"][1:] - obs["offset"][:-1]
    order = np.argsort(counts + rng.uniform(size=len(counts)), kind="stable")
    chunks = [order[i:i + batch_size] for i in range(0, len(order), batch_size)]
    rng.shuffle(chunks)
    return chunks


def predict(model, obs, idx, batch_size=4096):
    out_n, out_k = [], []
    model.eval()
    with torch.no_grad():
        for _, ld, val, mask in nn_lib.dense_batches(obs, idx, batch_size):
            feats = nn_lib.token_features(torch.from_numpy(ld), torch.from_numpy(val), torch.from_numpy(mask))
            n, lk = nn_lib.split_output(model(feats, torch.from_numpy(mask)))
            out_n.append(n.numpy())
            out_k.append(lk.numpy())
    model.train()
    return np.concatenate(out_n), np.concatenate(out_k)


def validate(model, val, lsq_err):
    idx = np.arange(len(val["normal"]))
    pred, log_kappa = predict(model, val, idx)
    err = nn_lib.angular_error_deg(pred, val["normal"])
    counts = val["offset"][1:] - val["offset"][:-1]
    figures = {"mean_deg": float(err.mean()), "median_deg": float(np.median(err)),
               "lsq_mean_deg": float(lsq_err.mean()), "buckets": {}}
    for lo, hi, name in BUCKETS:
        sel = (counts >= lo) & (counts <= hi)
        if sel.any():
            figures["buckets"][name] = {"sets": int(sel.sum()), "mean_deg": float(err[sel].mean()),
                                        "lsq_mean_deg": float(lsq_err[sel].mean())}
    # Is the confidence worth anything: the error of the least confident tenth against the rest.
    cut = np.quantile(log_kappa, 0.1)
    figures["mean_deg_least_confident_tenth"] = float(err[log_kappa <= cut].mean())
    figures["mean_deg_other_nine_tenths"] = float(err[log_kappa > cut].mean())
    figures["score"] = float(np.mean([b["mean_deg"] for b in figures["buckets"].values()]))
    return figures


def train_worker(design, train_path, val_path, args, out_path):
    """One design in a process of its own, on one core; its model and figures go to out_path."""
    torch.set_num_threads(1)
    train_obs = nn_lib.read_observations(train_path)
    val = nn_lib.read_observations(val_path)
    lsq_err = nn_lib.angular_error_deg(nn_lib.least_squares_normals(val, np.arange(len(val["normal"]))), val["normal"])
    model, config, fig = train(design, train_obs, val, lsq_err, args)
    torch.save({"state": model.state_dict(), "config": config, "figures": fig}, out_path)


def train(design, train_obs, val, lsq_err, args):
    torch.manual_seed(args.seed)
    rng = np.random.default_rng(args.seed)
    model, config = make_model(design)
    params = sum(p.numel() for p in model.parameters())
    opt = torch.optim.AdamW(model.parameters(), lr=args.lr, weight_decay=1e-5)
    steps = args.steps
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=args.lr, total_steps=steps, pct_start=0.05)
    start = time.time()
    step = 0
    print(f"train {design}: {params} parameters, {steps} steps of {args.batch} sets", flush=True)
    while step < steps:
        for chunk in batches_by_size(train_obs, args.batch, rng):
            if step >= steps:
                break
            _, ld, val_b, mask = next(nn_lib.dense_batches(train_obs, chunk, len(chunk)))
            normal = train_obs["normal"][chunk]
            ld, normal = augment(ld, normal, rng)
            mask = drop_tokens(mask, rng)
            mask_t = torch.from_numpy(mask)
            feats = nn_lib.token_features(torch.from_numpy(ld), torch.from_numpy(val_b), mask_t)
            n, log_kappa = nn_lib.split_output(model(feats, mask_t))
            cos = (n * torch.from_numpy(normal)).sum(dim=-1).clamp(-1 + 1e-6, 1 - 1e-6)
            loss = torch.acos(cos).mean() + 0.02 * vmf_nll(cos.detach(), log_kappa).mean()
            opt.zero_grad()
            loss.backward()
            torch.nn.utils.clip_grad_norm_(model.parameters(), 1.0)
            opt.step()
            sched.step()
            step += 1
            if step % 500 == 0 or step == steps:
                elapsed = time.time() - start
                print(f"  {design} step {step}/{steps} loss {loss.item():.4f} ({elapsed / 60:.1f} min, "
                      f"ETA {(steps - step) * elapsed / step / 60:.1f} min)", flush=True)
            if step % args.validate_every == 0 and step < steps:
                fig = validate(model, val, lsq_err)
                print(f"  {design} validation at {step}: mean {fig['mean_deg']:.3f} deg "
                      f"(lsq {fig['lsq_mean_deg']:.3f}), score {fig['score']:.3f}", flush=True)
    minutes = (time.time() - start) / 60
    fig = validate(model, val, lsq_err)
    fig.update({"design": design, "parameters": params, "steps": steps, "train_minutes": round(minutes, 1)})
    print(f"  {design}: {json.dumps(fig)}", flush=True)
    return model, config, fig


def write_vectors(model, val, path, count=48):
    """Inputs and PyTorch outputs for tests/solver/normal_network_test.cc: sets
    of every size bucket, in double-printed floats."""
    counts = val["offset"][1:] - val["offset"][:-1]
    picks = []
    for lo, hi, _ in BUCKETS:
        picks.extend(np.nonzero((counts >= lo) & (counts <= hi))[0][: count // len(BUCKETS)].tolist())
    idx = np.array(picks)
    pred, log_kappa = predict(model, val, idx, batch_size=1)
    with open(path, "w") as f:
        f.write("# scripts/train/train_normal_net.py: per set 'set K', K lines 'lx ly lz value', "
                "then 'out nx ny nz log_kappa' (the PyTorch forward pass of data/models/normal_net.bin)\n")
        for row, s in enumerate(idx):
            a, b = val["offset"][s], val["offset"][s + 1]
            f.write(f"set {b - a}\n")
            for k in range(a, b):
                l = val["light_dir"][k]
                f.write(f"{l[0]:.9g} {l[1]:.9g} {l[2]:.9g} {val['value'][k]:.9g}\n")
            n = pred[row]
            f.write(f"out {n[0]:.9g} {n[1]:.9g} {n[2]:.9g} {log_kappa[row]:.9g}\n")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scanbench", default=os.path.join(ROOT, "build", "app", "cli", "scanbench"))
    p.add_argument("--work", default=os.path.join(ROOT, "build", "train"), help="rendered sets and checkpoints")
    p.add_argument("--train-sets", type=int, default=2_000_000)
    p.add_argument("--val-sets", type=int, default=30_000)
    p.add_argument("--train-seed", type=int, default=20261204)
    p.add_argument("--val-seed", type=int, default=77)
    p.add_argument("--seed", type=int, default=1, help="torch and numpy seed of the training")
    p.add_argument("--designs", default="deepset2,settransformer")
    p.add_argument("--steps", type=int, default=20000, help="per design; 20 000 keeps both designs inside 2 hours on 2 cores")
    p.add_argument("--batch", type=int, default=256)
    p.add_argument("--lr", type=float, default=2e-3)
    p.add_argument("--validate-every", type=int, default=10000)
    p.add_argument("--threads", type=int, default=2, help="threads of the render")
    p.add_argument("--output", default=os.path.join(ROOT, "data", "models"))
    p.add_argument("--reuse", action="store_true", help="load designs already trained in --work instead of training")
    p.add_argument("--vectors", default=os.path.join(ROOT, "tests", "solver", "data", "normal_net_vectors.txt"))
    args = p.parse_args()

    os.makedirs(args.work, exist_ok=True)
    t0 = time.time()
    train_path = os.path.join(args.work, f"train_{args.train_seed}_{args.train_sets}.obs")
    val_path = os.path.join(args.work, f"val_{args.val_seed}_{args.val_sets}.obs")
    render(args.scanbench, train_path, args.train_seed, args.train_sets, args.threads)
    render(args.scanbench, val_path, args.val_seed, args.val_sets, args.threads)
    val = nn_lib.read_observations(val_path)

    designs = args.designs.split(",")
    outputs = {d: os.path.join(args.work, f"{d}.pt") for d in designs}
    context = multiprocessing.get_context("spawn")
    # --reuse: a design trained before in this work folder (same arguments) is
    # loaded, not trained again (e.g. to export one design while another trains).
    to_train = [d for d in designs if not (args.reuse and os.path.exists(outputs[d]))]
    workers = [context.Process(target=train_worker, args=(d, train_path, val_path, args, outputs[d])) for d in to_train]
    for w in workers:
        w.start()
    for w in workers:
        w.join()
        if w.exitcode != 0:
            sys.exit(f"train: a worker failed (exit code {w.exitcode})")
    results = []
    for d in designs:
        saved = torch.load(outputs[d])
        model, config = make_model(d)
        model.load_state_dict(saved["state"])
        results.append((saved["figures"]["score"], d, model, config, saved["figures"]))
    results.sort(key=lambda r: r[0])
    _, design, model, config, fig = results[0]

    os.makedirs(args.output, exist_ok=True)
    weights = os.path.join(args.output, "normal_net.bin")
    nn_lib.save_network(model, weights, config)
    with open(weights, "rb") as f:
        sha = hashlib.sha256(f.read()).hexdigest()
    os.makedirs(os.path.dirname(args.vectors), exist_ok=True)
    write_vectors(model, val, args.vectors)
    recipe = {
        "model": "data/models/normal_net.bin", "sha256": sha, "kept": design,
        "chosen_by": "the mean over light-count buckets of the mean angular error on the synthetic validation sets",
        "command": "scripts/train/train_normal_net.py " + " ".join(sys.argv[1:]),
        "arguments": {k: v for k, v in vars(args).items() if k not in ("scanbench", "work", "output", "vectors", "reuse")},
        "torch": torch.__version__, "total_minutes": round((time.time() - t0) / 60, 1),
        "validation": {r[1]: r[4] for r in results},
        "licence": "the weights are the project's own, trained only on its own renders; same licence as the code",
    }
    with open(os.path.join(args.output, "normal_net.json"), "w") as f:
        json.dump(recipe, f, indent=2)
        f.write("\n")
    print(f"kept {design}: {weights} sha256 {sha}; {recipe['total_minutes']} min in all")


if __name__ == "__main__":
    main()
