"""The registry of exploration methods: name -> factory.

A factory is called as `factory(task, config, rng, q_start, K)` with the trial's
`CompassConfig` (shared by every method so that all variants run with the same map,
validity and tree settings), an explicit generator, the start configuration [rad] and the
camera intrinsics; it returns an object following `base.ExplorationMethod`. Adding a method
is one module plus one line here. Ablations of COMPASS are entries that change the config.
"""
from __future__ import annotations

from dataclasses import replace
from typing import Callable

import numpy as np

from ..errors import CompassInputError
from .compass import CompassConfig, CompassMethod
from .baselines import fv_factory, gse_factory, ig_factory


def _compass(name: str, change: Callable[[CompassConfig], CompassConfig] = lambda c: c):
    def factory(task, config: CompassConfig, rng: np.random.Generator, q_start, K):
        return CompassMethod(task, change(config), rng, q_start, K, name=name)
    return factory


METHODS: dict[str, Callable] = {
    "compass": _compass("compass"),
    "compass-no-nfa": _compass("compass-no-nfa", lambda c: replace(c, nfa=replace(c.nfa, enabled=False))),
    "compass-no-heuristic": _compass(
        "compass-no-heuristic",
        lambda c: replace(c, weights=replace(c.weights, heuristic=0.0), tree=replace(c.tree, p_prior=0.0, p_hint=0.0))),
    "compass-no-momentum": _compass("compass-no-momentum",
                                    lambda c: replace(c, weights=replace(c.weights, momentum=0.0))),
    "compass-no-manip": _compass("compass-no-manip",
                                 lambda c: replace(c, weights=replace(c.weights, manipulability=0.0))),
    # COMPASS under the baselines' motion rule (unknown space outside the confined space
    # counts as free, Omega_safe included): the same rule for every method, to separate
    # what the view choice gains from what the near-field safety rule costs
    "compass-baseline-rule": _compass("compass-baseline-rule", lambda c: replace(c, near_field_unsafe=False)),
    "fv": fv_factory("fv"),
    "ig": ig_factory("ig"),
    "ig-occlusion": ig_factory("ig-occlusion"),
    "gse": gse_factory("gse"),
}


def available_methods() -> tuple[str, ...]:
    return tuple(METHODS)


def make_method(name: str, task, config: CompassConfig, rng: np.random.Generator, q_start, K):
    """Build the registered method `name`; unknown names raise CompassInputError listing them."""
    if name not in METHODS:
        raise CompassInputError(f"method {name!r} is not registered; use one of {', '.join(METHODS)}")
    return METHODS[name](task, config, rng, q_start, K)
