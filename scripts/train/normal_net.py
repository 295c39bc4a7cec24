"""The learned photometric solver's networks and their file format (issue #33).

Shared by train_normal_net.py and the test-vector writer; the C++ side
(solver/normal_network.{h,cc}) implements the same forward pass and reads the
same file. Per pixel the input is a SET of lights: tokens (direction in the
pixel's view frame, observation), any number >= 3, in any order.

Token features (token_features, mirrored by NormalNetwork::TokenFeatures in C++):
  l_x, l_y, l_z, x, sqrt(x)     with x = b / max_k(b), b the intensity-divided sample
so the network sees the shape of the observations, not the albedo, with
highlights compressed by the square root.

Outputs: a unit normal and log(kappa), the concentration of a von Mises-Fisher
distribution about it: the network's own estimate of how far it may be off
(the confidence map).
"""

import struct

import numpy as np
import torch
from torch import nn

FEATURES = 5


def token_features(light_dir, value, mask):
    """light_dir [B, K, 3], value [B, K], mask [B, K] bool -> [B, K, FEATURES]."""
    v = torch.where(mask, value.clamp(min=0.0), torch.zeros_like(value))
    peak = v.amax(dim=1, keepdim=True).clamp(min=1e-8)
    x = v / peak
    return torch.cat([light_dir, x.unsqueeze(-1), torch.sqrt(x).unsqueeze(-1)], dim=-1)


def masked_max(h, mask):
    return torch.where(mask.unsqueeze(-1), h, torch.full_like(h, -1e30)).amax(dim=1)


def masked_mean(h, mask):
    m = mask.unsqueeze(-1).to(h.dtype)
    return (h * m).sum(dim=1) / m.sum(dim=1).clamp(min=1.0)


class DeepSetNet(nn.Module):
    """Design A: two rounds of a per-token MLP and a pooled summary (max and
    mean), the second round seeing the first round's summary (PointNet-style
    context), then an MLP head. Cost: O(K) per pixel."""

    kind = "deepset2"

    def __init__(self, width=96, head=128):
        super().__init__()
        self.width, self.head_width = width, head
        self.phi1 = nn.ModuleList([nn.Linear(FEATURES, width), nn.Linear(width, width)])
        self.phi2 = nn.ModuleList([nn.Linear(width + 2 * width, width), nn.Linear(width, width)])
        self.rho = nn.ModuleList([nn.Linear(2 * width, head), nn.Linear(head, head // 2), nn.Linear(head // 2, 4)])

    def forward(self, feats, mask):
        h = torch.relu(self.phi1[0](feats))
        h = torch.relu(self.phi1[1](h))
        g = torch.cat([masked_max(h, mask), masked_mean(h, mask)], dim=-1)
        h2 = torch.cat([h, g.unsqueeze(1).expand(-1, h.shape[1], -1)], dim=-1)
        h2 = torch.relu(self.phi2[0](h2))
        h2 = torch.relu(self.phi2[1](h2))
        z = torch.cat([masked_max(h2, mask), masked_mean(h2, mask)], dim=-1)
        z = torch.relu(self.rho[0](z))
        z = torch.relu(self.rho[1](z))
        return self.rho[2](z)

    def tensors(self):
        out = []
        for name, layers in (("phi1", self.phi1), ("phi2", self.phi2), ("rho", self.rho)):
            for i, layer in enumerate(layers):
                out.append((f"{name}.{i}.weight", layer.weight))
                out.append((f"{name}.{i}.bias", layer.bias))
        return out


class SetTransformerNet(nn.Module):
    """Design B: per-pixel self-attention over the light tokens in the spirit of
    PS-Transformer (Ikehata 2021): an embedding MLP, `blocks` pre-norm
    transformer blocks (multi-head attention + MLP), max and mean pooling, an
    MLP head. Cost: O(K^2) per pixel in the attention."""

    kind = "settransformer"

    def __init__(self, width=64, heads=4, blocks=2, ffn=128, head=128):
        super().__init__()
        self.width, self.heads, self.blocks_count, self.ffn, self.head_width = width, heads, blocks, ffn, head
        self.embed = nn.ModuleList([nn.Linear(FEATURES, width), nn.Linear(width, width)])
        self.blocks = nn.ModuleList()
        for _ in range(blocks):
            self.blocks.append(nn.ModuleDict({
                "ln1": nn.LayerNorm(width), "qkv": nn.Linear(width, 3 * width), "out": nn.Linear(width, width),
                "ln2": nn.LayerNorm(width), "ff1": nn.Linear(width, ffn), "ff2": nn.Linear(ffn, width)}))
        self.rho = nn.ModuleList([nn.Linear(2 * width, head), nn.Linear(head, head // 2), nn.Linear(head // 2, 4)])

    def forward(self, feats, mask):
        b, k, _ = feats.shape
        h = torch.relu(self.embed[0](feats))
        h = self.embed[1](h)
        d = self.width // self.heads
        key_mask = (~mask).unsqueeze(1).unsqueeze(1)  # [B, 1, 1, K]
        for blk in self.blocks:
            x = blk["ln1"](h)
            q, kk, v = blk["qkv"](x).split(self.width, dim=-1)
            q = q.view(b, k, self.heads, d).transpose(1, 2)
            kk = kk.view(b, k, self.heads, d).transpose(1, 2)
            v = v.view(b, k, self.heads, d).transpose(1, 2)
            att = (q @ kk.transpose(-1, -2)) / (d ** 0.5)
            att = att.masked_fill(key_mask, -1e30).softmax(dim=-1)
            y = (att @ v).transpose(1, 2).reshape(b, k, self.width)
            h = h + blk["out"](y)
            h = h + blk["ff2"](torch.relu(blk["ff1"](blk["ln2"](h))))
        z = torch.cat([masked_max(h, mask), masked_mean(h, mask)], dim=-1)
        z = torch.relu(self.rho[0](z))
        z = torch.relu(self.rho[1](z))
        return self.rho[2](z)

    def tensors(self):
        out = [("embed.0.weight", self.embed[0].weight), ("embed.0.bias", self.embed[0].bias),
               ("embed.1.weight", self.embed[1].weight), ("embed.1.bias", self.embed[1].bias)]
        for i, blk in enumerate(self.blocks):
            for name in ("ln1", "qkv", "out", "ln2", "ff1", "ff2"):
                out.append((f"block{i}.{name}.weight", blk[name].weight))
                out.append((f"block{i}.{name}.bias", blk[name].bias))
        for i, layer in enumerate(self.rho):
            out.append((f"rho.{i}.weight", layer.weight))
            out.append((f"rho.{i}.bias", layer.bias))
        return out


def split_output(raw):
    """raw [B, 4] -> unit normal [B, 3], log kappa [B]."""
    n = raw[:, :3]
    n = n / n.norm(dim=-1, keepdim=True).clamp(min=1e-8)
    return n, raw[:, 3].clamp(-3.0, 12.0)


MAGIC = b"SCANBENCH-NORMAL-NET 1\n"


def save_network(model, path, config):
    """The file solver/normal_network.cc reads: the magic line, `key value`
    lines (the architecture), one `tensor NAME ROWS COLS` line per tensor, a
    `data` line, then every tensor's float32 values, little-endian, row-major,
    in the order listed."""
    lines = [f"kind {model.kind}"] + [f"{k} {v}" for k, v in config.items()]
    tensors = model.tensors()
    for name, t in tensors:
        rows, cols = (t.shape[0], t.shape[1]) if t.dim() == 2 else (t.shape[0], 1)
        lines.append(f"tensor {name} {rows} {cols}")
    lines.append("data")
    blob = b"".join(t.detach().cpu().numpy().astype("<f4").tobytes() for _, t in tensors)
    with open(path, "wb") as f:
        f.write(MAGIC + ("\n".join(lines) + "\n").encode() + blob)


def read_observations(path):
    """An observation file of `scanbench training-set` -> dict of numpy arrays."""
    import json
    with open(path, "rb") as f:
        magic = f.readline()
        if magic.strip() != b"SCANBENCH-OBSERVATIONS 1":
            raise ValueError(f"{path}: not an observation file")
        header = json.loads(f.readline())
        body = f.read()
    out = {"seed": header["seed"]}
    for a in header["arrays"]:
        count = int(np.prod(a["shape"]))
        arr = np.frombuffer(body, dtype=np.dtype(a["dtype"]), count=count, offset=a["offset"])
        out[a["name"]] = arr.reshape(a["shape"])
    return out


def dense_batches(obs, order, batch_size):
    """Yields (index array, light_dir [B,K,3], value [B,K], mask [B,K]) for the
    sets in `order` chunked by batch_size, padded to the chunk's largest set."""
    offset = obs["offset"]
    counts = offset[1:] - offset[:-1]
    for start in range(0, len(order), batch_size):
        idx = np.asarray(order[start:start + batch_size])
        n = counts[idx]
        b, k = len(idx), int(n.max())
        rows = np.repeat(np.arange(b), n)
        firsts = np.cumsum(n) - n
        cols = np.arange(int(n.sum())) - np.repeat(firsts, n)
        src = np.repeat(offset[idx], n) + cols
        ld = np.zeros((b, k, 3), np.float32)
        val = np.zeros((b, k), np.float32)
        mask = np.zeros((b, k), bool)
        ld[rows, cols] = obs["light_dir"][src]
        val[rows, cols] = obs["value"][src]
        mask[rows, cols] = True
        yield idx, ld, val, mask


def least_squares_normals(obs, idx):
    """The plain least-squares normal of each set (every sample kept)."""
    out = np.zeros((len(idx), 3))
    offset = obs["offset"]
    for row, s in enumerate(idx):
        L = obs["light_dir"][offset[s]:offset[s + 1]].astype(np.float64)
        b = obs["value"][offset[s]:offset[s + 1]].astype(np.float64)
        x, *_ = np.linalg.lstsq(L, b, rcond=None)
        nrm = np.linalg.norm(x)
        out[row] = x / nrm if nrm > 0 else np.array([0, 0, 1.0])
    return out


def angular_error_deg(a, b):
    cos = np.clip(np.sum(a * b, axis=-1), -1.0, 1.0)
    return np.degrees(np.arccos(cos))


def pack_floats(values):
    return struct.pack(f"<{len(values)}f", *values)
