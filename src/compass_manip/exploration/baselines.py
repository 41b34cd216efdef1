"""Factories of the baselines (FV, IG, GSE) for `registry.METHODS`.

Each takes the trial's `CompassConfig` only for its `world` part (the shared map,
validity and frontier settings), so every baseline maps, checks and plans exactly as
COMPASS does; its own view-selection config is the module's frozen default below
(documented in docs/baselines.md with the sweep that chose it).
"""
from __future__ import annotations

import numpy as np

from .fixed_views import FixedViewsConfig, FixedViewsMethod
from .greedy_ig import GreedyIGConfig, GreedyIGMethod
from .gse import GSEConfig, GSEMethod
from .ig_formulations import IGFormulation

#: The baselines' view-selection configs (chosen on development seeds, docs/baselines.md).
FV_CONFIG = FixedViewsConfig()
IG_CONFIGS = {
    "ig": GreedyIGConfig(formulation=IGFormulation.UNOBSERVED),
    "ig-occlusion": GreedyIGConfig(formulation=IGFormulation.OCCLUSION_AWARE, min_information=4.0),
}
GSE_CONFIG = GSEConfig()


def fv_factory(name: str, config: FixedViewsConfig = FV_CONFIG):
    def factory(task, compass_config, rng: np.random.Generator, q_start, K):
        return FixedViewsMethod(task, compass_config.world, config, rng, q_start, K, name=name)
    return factory


def ig_factory(name: str, config: GreedyIGConfig | None = None):
    config = config if config is not None else IG_CONFIGS[name]

    def factory(task, compass_config, rng: np.random.Generator, q_start, K):
        return GreedyIGMethod(task, compass_config.world, config, rng, q_start, K, name=name)
    return factory


def gse_factory(name: str, config: GSEConfig = GSE_CONFIG):
    def factory(task, compass_config, rng: np.random.Generator, q_start, K):
        return GSEMethod(task, compass_config.world, config, rng, q_start, K, name=name)
    return factory
