"""The terms of the MUE-RRT utility U(x) = w . [G, D, M, H] / C as pure functions on arrays.

G information gain (unknown voxels a view would see; computed by `mapping.infogain`),
D exploration momentum, M Yoshikawa manipulability (`robot.kinematics`), H heuristic
guidance towards points of interest, C joint-space motion cost. Positions in [m], joint
paths in [rad].

Our reading of D: the paper writes (t_prev - t_root) . (t_x - t_root) with t_prev the
previously selected viewpoint; taken literally with t_prev the view before the current one,
that rewards turning back. We reward keeping the direction of travel:
D = (t_root - t_prev) . (t_x - t_root), which is what the paper says the term is for.

The terms live on different scales (voxels, m^2, m^3/rad-ish, cosines), so `utility`
normalises G, D and M by their largest magnitude over the candidate set before weighting;
H is a cosine already. C gets a constant offset so that nodes next to the root do not win
by dividing by almost nothing.
"""
from __future__ import annotations

import numpy as np


def momentum(t_prev: np.ndarray, t_root: np.ndarray, t_x: np.ndarray) -> np.ndarray:
    """D (N,) [m^2] = (t_root - t_prev) . (t_x - t_root) for view positions t_x (N, 3)."""
    t_root = np.asarray(t_root, float)
    return (np.asarray(t_x, float) - t_root) @ (t_root - np.asarray(t_prev, float))


def heuristic(view_axes: np.ndarray, t_v: np.ndarray, points: np.ndarray) -> np.ndarray:
    """H (N,) = max over points p (P, 3) of axis . (p - t_v) / |p - t_v| for views with unit
    viewing axes (N, 3) at positions t_v (N, 3); 0 when there are no points."""
    axes = np.asarray(view_axes, float).reshape(-1, 3)
    P = np.asarray(points, float).reshape(-1, 3)
    if len(P) == 0:
        return np.zeros(len(axes))
    d = P[None, :, :] - np.asarray(t_v, float).reshape(-1, 1, 3)
    n = np.linalg.norm(d, axis=-1)
    cos = np.einsum("nk,npk->np", axes, d) / np.maximum(n, 1e-9)
    return cos.max(axis=1)


def motion_cost(paths: list[np.ndarray]) -> np.ndarray:
    """C (N,) [rad]: joint-space length of each path (m_i, 7) from q_current."""
    return np.array([float(np.sum(np.linalg.norm(np.diff(np.asarray(p, float), axis=0), axis=1))) for p in paths])


#: numpy sums up to this many terms one after another (longer sums are pairwise)
_SEQUENTIAL_TERMS = 7


def tree_path_costs(Q: np.ndarray, parent: np.ndarray) -> np.ndarray:
    """`motion_cost([path_to(k) for k in range(N)])` of a tree with nodes Q (N, 7) [rad]
    and parents (N,) (-1 at the root; parents precede their children), bit for bit, without
    building the paths: a node at most 7 edges deep costs its parent's cost plus its edge
    (numpy sums up to 7 terms in order), a deeper one the numpy sum of its edges."""
    Q = np.asarray(Q, float)
    parent = np.asarray(parent)[: len(Q)]
    C = np.zeros(len(Q))
    if len(Q) < 2:
        return C
    step = np.zeros(len(Q))
    step[1:] = np.linalg.norm(Q[1:] - Q[parent[1:]], axis=1)
    depth = np.zeros(len(Q), dtype=np.int64)
    for k in range(1, len(Q)):
        p = int(parent[k])
        depth[k] = depth[p] + 1
        if depth[k] <= _SEQUENTIAL_TERMS:
            C[k] = C[p] + step[k]
        else:
            chain, j = [], k
            while j > 0:
                chain.append(step[j])
                j = int(parent[j])
            C[k] = float(np.sum(np.array(chain[::-1])))
    return C


def normalise(x: np.ndarray) -> np.ndarray:
    """x divided by its largest magnitude (zeros stay zeros)."""
    x = np.asarray(x, dtype=float)
    m = np.max(np.abs(x)) if x.size else 0.0
    return x / m if m > 0 else np.zeros_like(x)


def utility(G: np.ndarray, D: np.ndarray, M: np.ndarray, H: np.ndarray, C: np.ndarray,
            weights: tuple[float, float, float, float], cost_offset: float) -> np.ndarray:
    """U (N,) = (w_g G/max|G| + w_d D/max|D| + w_m M/max|M| + w_h H) / (C + cost_offset)."""
    wg, wd, wm, wh = weights
    num = wg * normalise(G) + wd * normalise(D) + wm * normalise(M) + wh * np.asarray(H, float)
    return num / (np.asarray(C, float) + cost_offset)
