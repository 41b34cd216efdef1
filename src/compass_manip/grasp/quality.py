"""GraspNet's analytic grasp score (Fang et al., CVPR 2020, Sec. 3.2).

A parallel-jaw grasp with contacts p1, p2 and outward surface normals n1, n2 is
force-closure under friction coefficient mu when each inward normal lies within the
friction cone half-angle arctan(mu) of the closing line (the antipodal test of Nguyen 1988).
GraspNet labels a grasp with the smallest mu in {0.1, 0.2, ..., 1.0} at which it is
force-closure and scores it s = 1.1 - mu, so s in {0.1, ..., 1.0}; a grasp that is not
force-closure even at mu = 1.0 scores 0.

A contact on an edge (a box's rim, a can's top rim) has no single normal: every normal of the
cone between the faces that meet there is a normal it may push along. `required_mu_cones` /
`graspnet_score_cones` score such a pair with the same definition, the pair counting as
force-closure at mu only when every normal of both contacts' cones is within arctan(mu) of
the closing line (a contact with one normal is a cone of one).
"""
from __future__ import annotations

import numpy as np

from ..errors import CompassInputError

#: GraspNet's friction coefficients, smallest first.
MU_GRID = np.round(np.arange(1, 11) / 10.0, 1)


def _unit(v: np.ndarray, name: str) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    if np.any(n < 1e-12) or not np.all(np.isfinite(v)):
        raise CompassInputError(f"{name} must be finite, non-zero 3-vectors")
    return v / n


def required_mu(p1, p2, n1, n2) -> np.ndarray:
    """(N,) smallest friction coefficient making each pair force-closure (continuous):
    max over both contacts of tan(angle between the inward normal and the closing line).
    p1, p2 (N,3) [m] contact points; n1, n2 (N,3) outward surface normals. inf where a
    normal points along or away from the closing line (angle >= 90 deg)."""
    p1, p2, n1, n2 = (np.atleast_2d(np.asarray(a, dtype=np.float64)) for a in (p1, p2, n1, n2))
    if not (p1.shape == p2.shape == n1.shape == n2.shape and p1.shape[-1] == 3):
        raise CompassInputError(f"contacts and normals must all be (N, 3), got {p1.shape}, {p2.shape}, "
                                f"{n1.shape}, {n2.shape}")
    line = _unit(p2 - p1, "p2 - p1 (coincident contacts)")
    n1, n2 = _unit(n1, "n1"), _unit(n2, "n2")
    c1 = np.sum(-n1 * line, axis=1)   # contact 1 pushes along +line
    c2 = np.sum(-n2 * -line, axis=1)  # contact 2 pushes along -line
    return _tan_of_cos(np.minimum(c1, c2))


def _tan_of_cos(c: np.ndarray) -> np.ndarray:
    """tan of the angle whose cosine is c; inf where the angle is 90 deg or more."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(c > 1e-12, np.sqrt(np.maximum(0.0, 1.0 - c * c)) / np.maximum(c, 1e-12), np.inf)


def required_mu_cones(p1, p2, cone1, cone2) -> np.ndarray:
    """(N,) smallest friction coefficient at which each pair is force-closure for every
    normal of its contacts' cones: p1, p2 (N,3) [m]; cone1, cone2 (N,K,3) outward normals each
    contact may have (repeat a normal to fill a cone of fewer than K)."""
    p1, p2 = (np.atleast_2d(np.asarray(a, dtype=np.float64)) for a in (p1, p2))
    cone1, cone2 = (np.asarray(a, dtype=np.float64) for a in (cone1, cone2))
    if cone1.ndim == 2:
        cone1, cone2 = cone1[None], cone2[None]
    if not (p1.shape == p2.shape and p1.shape[-1] == 3 and cone1.shape == cone2.shape
            and cone1.shape[0] == p1.shape[0] and cone1.shape[-1] == 3 and cone1.ndim == 3):
        raise CompassInputError(f"contacts must be (N, 3) and cones (N, K, 3), got {p1.shape}, {p2.shape}, "
                                f"{cone1.shape}, {cone2.shape}")
    line = _unit(p2 - p1, "p2 - p1 (coincident contacts)")
    cone1, cone2 = _unit(cone1, "cone1"), _unit(cone2, "cone2")
    c1 = np.min(np.einsum("nkj,nj->nk", -cone1, line), axis=1)
    c2 = np.min(np.einsum("nkj,nj->nk", cone2, line), axis=1)
    return _tan_of_cos(np.minimum(c1, c2))


def mu_label(need: np.ndarray) -> np.ndarray:
    """GraspNet's label of continuous required friction coefficients `need` (N,): the
    smallest mu in MU_GRID >= need, NaN where none is (a tolerance of 1e-9 keeps exact
    thresholds on their grid value)."""
    idx = np.searchsorted(MU_GRID, np.asarray(need, dtype=np.float64) - 1e-9, side="left")
    out = np.full(need.shape, np.nan)
    ok = idx < len(MU_GRID)
    out[ok] = MU_GRID[idx[ok]]
    return out


def graspnet_mu(p1, p2, n1, n2) -> np.ndarray:
    """(N,) GraspNet's label: the smallest mu in MU_GRID at which the pair is force-closure,
    NaN where none is."""
    return mu_label(required_mu(p1, p2, n1, n2))


def score_of_mu(mu: np.ndarray) -> np.ndarray:
    """GraspNet's score s = 1.1 - mu of labels mu (NaN: not force-closure, s = 0)."""
    mu = np.asarray(mu, dtype=np.float64)
    return np.where(np.isnan(mu), 0.0, np.round(1.1 - np.nan_to_num(mu, nan=1.1), 1))


def graspnet_score(p1, p2, n1, n2) -> np.ndarray:
    """(N,) GraspNet's score s = 1.1 - mu (in {0.1, ..., 1.0}), 0 where not force-closure."""
    return score_of_mu(graspnet_mu(p1, p2, n1, n2))


def graspnet_score_cones(p1, p2, cone1, cone2) -> np.ndarray:
    """(N,) GraspNet's score with every normal of each contact's cone (`required_mu_cones`)."""
    return score_of_mu(mu_label(required_mu_cones(p1, p2, cone1, cone2)))
