"""CHOICE Fig. 11 at toy scale: where the planner's latent fits of unseen layouts land among its training codes.

The auto-decoder keeps one code ``z_i`` per training interaction (Eq. 7); at run time a code is fitted to an unseen
scene (Eq. 9). :func:`latent_map` fits one for each unseen layout of Table 3's test (``table3.planning_cases``
without reshaping; the best of the latent initialisations, as ``intp.plan_each_init`` plans) and embeds the training
codes and the fitted ones together in two dimensions with t-SNE (scikit-learn), as the paper's Fig. 11 shows them.
The fits and the embedding take tens of seconds, so the result goes through the artifact cache.
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import numpy as np

from ...infra import load_or_build
from . import interactions, intp, table3
from .interactions import PlannerDataConfig
from .intp import PlannerConfig

__all__ = ["LatentMap", "latent_map"]


@dataclass
class LatentMap:
    """The planner's codes and the unseen layouts' fitted codes, embedded together.

    Attributes:
        codes: ``(N, latent)`` the training interactions' codes ``z_i``.
        fitted: ``(M, latent)`` the code fitted to each unseen layout (the best initialisation).
        embedded: ``(N + M, 2)`` t-SNE of ``codes`` then ``fitted``.
        sources: ``(M,)`` int, the test interaction each layout comes from (``PlanningCase.source``).
        conditions: ``(M, 4)`` each layout's condition ``c``.
        seconds: what the fits and the embedding took when they were computed.
    """

    codes: np.ndarray
    fitted: np.ndarray
    embedded: np.ndarray
    sources: np.ndarray
    conditions: np.ndarray
    seconds: float


def latent_map(data_config: PlannerDataConfig, config: PlannerConfig, *, seed: int = 0, perplexity: float = 15.0,
               device="cpu") -> LatentMap:
    """Fit a code to every unseen layout of Table 3 (``table3.planning_cases(..., reshape=False, seed=seed)``) with
    ``intp.trained_planner(data_config, config)``, and embed the training codes and the fitted ones with t-SNE
    (``perplexity``, PCA initialisation, ``random_state=seed``); computed once, then loaded from the cache."""
    if not perplexity > 0:
        raise ValueError(f"perplexity: expected a positive number, got {perplexity!r}")

    def build():
        from sklearn.manifold import TSNE

        clock = time.perf_counter()
        model = intp.trained_planner(data_config, config, device=device).model
        train = interactions.interaction_set(data_config, "train")
        test = interactions.interaction_set(data_config, "test")
        unseen = table3.planning_cases(test, data_config.field, reshape=False, seed=seed)
        fitted = np.stack([intp.plan_each_init(model, config, train, c.scene, c.condition, c.start, c.goal)[0]
                           .code.numpy() for c in unseen])
        codes = model.codes.weight.detach().numpy()
        embedded = TSNE(n_components=2, perplexity=perplexity, init="pca",
                        random_state=seed).fit_transform(np.concatenate([codes, fitted]))
        return {"codes": codes, "fitted": fitted, "embedded": embedded,
                "sources": np.array([c.source for c in unseen], dtype=np.int64),
                "conditions": np.stack([np.asarray(c.condition, dtype=np.float32) for c in unseen]),
                "seconds": time.perf_counter() - clock}

    key = {"data": dataclasses.asdict(data_config), "model": dataclasses.asdict(config), "seed": int(seed),
           "perplexity": float(perplexity)}
    artifact = load_or_build("choice_latent_map", key, build)
    return LatentMap(**{name: artifact[name] for name in ("codes", "fitted", "embedded", "sources", "conditions")},
                     seconds=float(artifact["seconds"]))
