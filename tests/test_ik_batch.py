"""The compiled IK path (one batched refinement per sweep, compiled dedupe and rigidity test)
gives the same solutions, bit for bit, as the per-candidate Python path it replaced."""
import numpy as np
import pytest

from compass_manip.geometry import is_rigid
from compass_manip.robot.ik import IKConfig, IKResult, PandaIK, _ordered
from compass_manip.robot.ik_kernels import refine_kernel
from compass_manip.robot.model import Q_MAX, Q_MIN
from compass_manip.exploration.viewpoints import sample_direction_in_cone, view_pose
from _rigid_reference import is_rigid_reference


def _sweep_reference(ik, T_world_hand, T_base_flange, q_ref, n_q7):
    """The per-candidate loop of the code before the batched kernel."""
    config = ik.config
    q7s = np.concatenate([[q_ref[6]], np.linspace(Q_MIN[6], Q_MAX[6], n_q7 + 2)[1:-1]])
    cands = []
    for q7 in q7s:
        S = ik._frankik.ik_full(T_base_flange, q_ref, float(q7))
        cands.extend(S[np.all(np.isfinite(S), axis=1)])
    args = ik.kin.kernel_args()
    sols, pes, res = [], [], []
    for q in cands:
        q = np.clip(q, Q_MIN, Q_MAX)
        qr, pe, re = refine_kernel(q, T_world_hand, ik.kin.hand_index, *args, Q_MIN, Q_MAX,
                                   config.refine_iters, config.damping, config.tol_pos, config.tol_rot)
        if pe <= config.tol_pos and re <= config.tol_rot:
            sols.append(qr)
            pes.append(pe)
            res.append(re)
    return np.array(sols).reshape(-1, 7), np.array(pes), np.array(res), len(cands)


def _ordered_reference(S, pe, re, T, q_ref, tol, frame, failure):
    order = np.argsort(np.linalg.norm(S - q_ref, axis=1), kind="stable")
    near = np.max(np.abs(S[:, None, :] - S[None, :, :]), axis=2) <= tol if len(S) else np.zeros((0, 0), bool)
    keep, blocked = [], np.zeros(len(S), dtype=bool)
    for i in order:
        if not blocked[i]:
            keep.append(int(i))
            blocked |= near[i]
    k = np.array(keep, np.int64)
    return IKResult(S[k].reshape(-1, 7), pe[k], re[k], np.array(T)[k].reshape(-1, 4, 4), frame, failure)


def _camera_targets(n, seed):
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        d = sample_direction_in_cone(np.array([1.0, 0.0, -0.3]), 0.8, rng)
        p = np.array([0.55, 0.0, 0.45]) + rng.uniform(-0.2, 0.2, 3)
        out.append(view_pose(p, d, rng.uniform(0.2, 0.45), rng.uniform(-np.pi / 2, np.pi / 2)))
    return out


@pytest.mark.parametrize("strict", [False, True])
def test_batched_sweep_equals_the_per_candidate_loop_bit_for_bit(strict):
    # strict: no refinement and a tolerance frankik's candidates miss (about 1e-12 m off): rejections
    ik = PandaIK(config=IKConfig(refine_iters=0, tol_pos=1e-12, tol_rot=1e-12)) if strict else PandaIK()
    q_ref = np.array([0.1, -0.5, 0.0, -2.0, 0.0, 1.6, 0.8])
    n_solved = n_cands = 0
    for T in _camera_targets(60, 3):
        T_world_hand = T @ np.linalg.inv(ik.kin.T_hand_frame("cam"))
        T_base_flange = ik.T_base_world @ T_world_hand @ ik.T_hand_link8
        for n_q7 in (3, 16):
            S, pe, re, n = ik._sweep(T_world_hand, T_base_flange, q_ref, n_q7)
            S0, pe0, re0, n0 = _sweep_reference(ik, T_world_hand, T_base_flange, q_ref, n_q7)
            assert n == n0
            assert np.array_equal(S, S0) and np.array_equal(pe, pe0) and np.array_equal(re, re0)
            n_solved += len(S)
            n_cands += n
    assert n_solved > 100 if not strict else n_solved < n_cands


def test_compiled_dedupe_keeps_the_same_solutions_as_the_pairwise_matrix():
    rng = np.random.default_rng(5)
    q_ref = np.zeros(7)
    for n in (0, 1, 2, 7, 30):
        S = rng.normal(0.0, 0.0003, (n, 7)) + rng.integers(0, 3, (n, 1)) * 0.5  # clusters of near duplicates
        pe, re = rng.uniform(0, 1e-5, n), rng.uniform(0, 1e-5, n)
        T = np.broadcast_to(np.eye(4), (n, 4, 4))
        a = _ordered(S, pe, re, T, q_ref, 1e-3, "cam", None)
        b = _ordered_reference(S, pe, re, T, q_ref, 1e-3, "cam", None)
        assert np.array_equal(a.solutions, b.solutions) and np.array_equal(a.pos_err, b.pos_err)
        assert np.array_equal(a.T_world_targets, b.T_world_targets)
        if n >= 7:
            assert 0 < len(a.solutions) < n  # some were near duplicates


@pytest.mark.parametrize("seed", [0, 1])
def test_solve_equals_the_reference_path(seed):
    ik = PandaIK()
    q_ref = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 1.9, 0.7])
    for T in _camera_targets(25, seed):
        r = ik.solve(T, "cam", q_ref, 3, retry=False)
        T_world_hand = T @ np.linalg.inv(ik.kin.T_hand_frame("cam"))
        S, pe, re, _ = _sweep_reference(ik, T_world_hand, ik.T_base_world @ T_world_hand @ ik.T_hand_link8, q_ref, 3)
        ref = _ordered_reference(S, pe, re, np.broadcast_to(T, (len(S), 4, 4)), q_ref, ik.config.dedupe_tol, "cam",
                                 None)
        assert np.array_equal(r.solutions, ref.solutions) and np.array_equal(r.rot_err, ref.rot_err)


def test_compiled_rigidity_test_agrees_with_numpy():
    rng = np.random.default_rng(2)
    for k in range(300):
        A = rng.normal(size=(3, 3))
        Q, _ = np.linalg.qr(A)
        T = np.eye(4)
        T[:3, :3] = Q * np.sign(np.linalg.det(Q))
        T[:3, 3] = rng.normal(size=3)
        kind = k % 5
        if kind == 1:
            T[:3, :3] += rng.normal(0, 10 ** rng.uniform(-8, -3), (3, 3))  # near the tolerance
        elif kind == 2:
            T[:3, :3] *= -1.0  # a reflection
        elif kind == 3:
            T[3, rng.integers(4)] += 10 ** rng.uniform(-8, -3)
        elif kind == 4:
            T[rng.integers(4), rng.integers(4)] = np.nan
        assert is_rigid(T, 1e-5) == is_rigid_reference(T, 1e-5), (k, kind)
    assert not is_rigid(np.eye(3)) and is_rigid(np.eye(4, dtype=np.float32)) and not is_rigid(np.full((4, 4), "a"))
