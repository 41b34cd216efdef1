"""Compiled parts of the Panda's IK (`robot.ik`): damped-least-squares refinement of one
candidate towards a hand-flange pose and of a batch of them, and the greedy dedupe of
solutions by joint distance."""
from __future__ import annotations

import math

import numba as nb
import numpy as np

from .kinematics import fk_links_kernel, jacobian_kernel


@nb.njit(cache=True)
def _rot_log(R):
    """Rotation vector [rad] of a rotation matrix."""
    c = min(1.0, max(-1.0, 0.5 * (R[0, 0] + R[1, 1] + R[2, 2] - 1.0)))
    a = math.acos(c)
    v = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    s = math.sin(a)
    if s < 1e-9:
        if c > 0:
            return 0.5 * v
        # angle ~ pi: axis from the diagonal
        ax = np.sqrt(np.maximum(0.0, (np.array([R[0, 0], R[1, 1], R[2, 2]]) + 1.0) / 2.0))
        k = int(np.argmax(ax))
        for i in range(3):
            if i != k and R[k, i] + R[i, k] < 0:
                ax[i] = -ax[i]
        return a * ax / np.linalg.norm(ax)
    return v * (a / (2.0 * s))


@nb.njit(cache=True)
def refine_kernel(q0, T_world_target_hand, hand_index, finger_pos, parent, T_parent_link, joint_kind,
                  joint_index, axis, anchor, qmin, qmax, iters, damping, tol_pos, tol_rot):
    """DLS refinement of q0 towards a hand-flange pose. Returns (q, pos_err [m], rot_err [rad])."""
    q = q0.copy()
    links = np.empty((parent.shape[0], 4, 4))
    J = np.empty((6, 7))
    e = np.empty(6)
    pe, re = np.inf, np.inf
    for it in range(iters + 1):
        fk_links_kernel(q, finger_pos, parent, T_parent_link, joint_kind, joint_index, axis, anchor, links)
        T = links[hand_index]
        for r in range(3):
            e[r] = T_world_target_hand[r, 3] - T[r, 3]
        R_err = np.ascontiguousarray(T_world_target_hand[:3, :3]) @ np.ascontiguousarray(T[:3, :3].T)
        w = _rot_log(R_err)
        e[3:] = w
        pe = math.sqrt(e[0] ** 2 + e[1] ** 2 + e[2] ** 2)
        re = math.sqrt(w[0] ** 2 + w[1] ** 2 + w[2] ** 2)
        if (pe < tol_pos and re < tol_rot) or it == iters:
            break
        jacobian_kernel(links, T[:3, 3].copy(), joint_kind, joint_index, axis, anchor, J)
        A = J @ J.T + damping**2 * np.eye(6)
        dq = J.T @ np.linalg.solve(A, e)
        for j in range(7):
            q[j] = min(qmax[j], max(qmin[j], q[j] + dq[j]))
    return q, pe, re


@nb.njit(cache=True)
def refine_batch_kernel(C, T_world_target_hand, hand_index, finger_pos, parent, T_parent_link, joint_kind,
                        joint_index, axis, anchor, qmin, qmax, iters, damping, tol_pos, tol_rot):
    """`refine_kernel` on every candidate row of C (n, 7) [rad], each clipped to qmin..qmax
    first: (Q (n, 7), pos_err (n,) [m], rot_err (n,) [rad], ok (n,) where both errors are
    within tol_pos / tol_rot)."""
    n = C.shape[0]
    Q = np.empty((n, 7))
    pe = np.empty(n)
    re = np.empty(n)
    ok = np.zeros(n, np.bool_)
    q0 = np.empty(7)
    for i in range(n):
        for j in range(7):
            q0[j] = min(qmax[j], max(qmin[j], C[i, j]))
        q, p, r = refine_kernel(q0, T_world_target_hand, hand_index, finger_pos, parent, T_parent_link, joint_kind,
                                joint_index, axis, anchor, qmin, qmax, iters, damping, tol_pos, tol_rot)
        Q[i] = q
        pe[i] = p
        re[i] = r
        ok[i] = p <= tol_pos and r <= tol_rot
    return Q, pe, re, ok


@nb.njit(cache=True)
def dedupe_kernel(S, order, tol):
    """Indices of S (n, 7) kept, in `order`: each row unless a kept row is within tol of it
    (max joint difference)."""
    keep = np.empty(len(order), np.int64)
    n_keep = 0
    for i in order:
        near = False
        for t in range(n_keep):
            d = 0.0
            for j in range(S.shape[1]):
                d = max(d, abs(S[i, j] - S[keep[t], j]))
            if d <= tol:
                near = True
                break
        if not near:
            keep[n_keep] = i
            n_keep += 1
    return keep[:n_keep]
