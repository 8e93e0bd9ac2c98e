"""Choose the guidance step size α of each NIFTY guidance variant by one protocol, bracketed.

NIFTY does not state α (Eq. 4). Every variant the chapters guide with -- the offset field (NIFTY), the distance
field (Table 2), the non-parametric nearest anchor (Table 3), the 5-frame field (Table 6) and the human-frame field
(Table 7) -- gets its α from the same protocol, on training conditions, never on the test scenes
(``nifty.evaluation.guidance_alpha_sweep`` and ``chosen_alpha``): for each α tried, N guided candidates for each of
the 16 training conditions per action, the one with the lowest final objective kept (N = 10, as the tables sample);
the α with the lowest median skeleton distance, sit and lift pooled; over several seeds, the α whose worst seed's
median is lowest (``evaluation.chosen_alpha_over_seeds``: one α serves every seed a reader may type). The α tried
are the library's current one and its neighbours on ``evaluation.ALPHA_GRID``, then further out while the choice
lies at an end of those tried, so every choice is bracketed (a worse α on each side) unless the grid runs out,
which it says. It prints each seed's medians and choice beside the worst-seed one, the every-seed-pooled one and
the library's. Chapter 5 measures the last denoising step on the same conditions.

It measures and never gates (exit code 0). Models, fields and each α's samples are built or loaded from the artifact
cache (``$HOI_CACHE``), one per CPU core.

    python scripts/choose_guidance_alpha.py                  # toy, seed 0 (the library's values), N = 10
    python scripts/choose_guidance_alpha.py --seeds 0 1 2    # by the worst seed, each seed's choice shown
    python scripts/choose_guidance_alpha.py --seeds 3 --n-samples 1 --variants "offset (NIFTY)"
"""
import argparse
import functools
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import pandas as pd  # noqa: E402

from hoi_tutorial.infra import warm_cache  # noqa: E402
from hoi_tutorial.nifty import data, evaluation, guidance  # noqa: E402
from hoi_tutorial.nifty import interaction_field as fields  # noqa: E402
from hoi_tutorial.nifty import motion_model as mm  # noqa: E402

ACTIONS = ("sit", "lift")
# name -> (field overrides, or None for the non-parametric field; objective)
VARIANTS = {
    "offset (NIFTY)": ({}, "field"),
    "distance (Table 2)": ({"output": "distance"}, "field"),
    "nearest anchor (Table 3)": (None, "nearest_anchor"),
    "5 frames (Table 6)": ({"n_frames": 5}, "field"),
    "human frame (Table 7)": ({"frame": "human"}, "field"),
}


def setup(scale, seed):
    """The configs of one seed: ``(data, model, evaluation, {(action, variant): field or None})``."""
    data_configs = {a: data.synthetic_data_config(a, scale, seed=seed) for a in ACTIONS}
    model_configs = {a: mm.motion_model_config(a, scale, seed=seed) for a in ACTIONS}
    field_configs = {(a, name): None if overrides is None else
                     fields.interaction_field_config(a, scale, seed=seed, **overrides)
                     for a in ACTIONS for name, (overrides, _) in VARIANTS.items()}
    return data_configs, model_configs, evaluation.evaluation_config(scale, seed=seed), field_configs


def sweeps(scale, seeds, tried, n_samples):
    """``{(seed, action, variant): AlphaSweep}`` over each variant's α in ``tried``, built one per core (each
    (seed, action, variant, α) its own artifact), then loaded."""
    configs = {seed: setup(scale, seed) for seed in seeds}
    first, rest, calls = [], [], {}
    for seed, (data_configs, model_configs, eval_config, field_configs) in configs.items():
        data.trained_prior(data_configs[ACTIONS[0]])
        warm_cache([functools.partial(evaluation.build_evaluation, data_configs[a], model_configs[a], eval_config)
                    for a in ACTIONS])
        for name in tried:
            objective = VARIANTS[name][1]
            for a in ACTIONS:
                args = (data_configs[a], model_configs[a], field_configs[(a, name)], eval_config)
                calls[(seed, a, name)] = args
                jobs = [functools.partial(evaluation.build_alpha_sweep, *args, alphas=(alpha,), objective=objective,
                                          n_samples=n_samples) for alpha in sorted(tried[name])]
                first, rest = first + jobs[:1], rest + jobs[1:]
    # Each field's first α trains it; its other α then only load it (no two workers wait on one field).
    warm_cache(first + rest)
    datasets = {(seed, a): data.synthesize(configs[seed][0][a], progress=False) for seed in seeds for a in ACTIONS}
    out = {}
    for (seed, a, name), (_, model_config, field_config, eval_config) in calls.items():
        out[(seed, a, name)] = evaluation.guidance_alpha_sweep(datasets[(seed, a)], model_config, field_config,
                                                               eval_config,
                                                               alphas=tuple(sorted(tried[name])),
                                                               objective=VARIANTS[name][1], n_samples=n_samples)
    return out


def next_alpha(tried, best, grid):
    """The step size to try next: the grid's next one beyond ``best`` where ``best`` lies at an end of those
    ``tried`` (no worse α tried on that side), else ``None`` (bracketed, or the grid runs out)."""
    alphas, i = sorted(tried), grid.index(best)
    if best == alphas[0] and i > 0:
        return grid[i - 1]
    if best == alphas[-1] and i < len(grid) - 1:
        return grid[i + 1]
    return None


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scale", default="toy")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0])
    parser.add_argument("--n-samples", type=int, default=10, help="candidates per condition, the best by G kept")
    parser.add_argument("--variants", nargs="+", choices=list(VARIANTS), default=list(VARIANTS), metavar="VARIANT",
                        help=f"the variants to choose for (default all: {', '.join(VARIANTS)})")
    args = parser.parse_args(argv)
    variants = {name: VARIANTS[name] for name in args.variants}
    pd.set_option("display.width", 160)
    grid = evaluation.ALPHA_GRID
    field_configs = setup(args.scale, args.seeds[0])[3]
    library = {name: guidance.step_size(field_configs[(ACTIONS[0], name)], objective)
               for name, (_, objective) in variants.items()}
    # Start at the library's α and its neighbours; go outwards while the choice lies at an end of those tried.
    tried = {}
    for name, alpha in library.items():
        i = grid.index(alpha)
        tried[name] = set(grid[max(i - 1, 0):i + 2])
    while True:
        results = sweeps(args.scale, args.seeds, tried, args.n_samples)
        grown = False
        for name in variants:
            best = evaluation.chosen_alpha_over_seeds({seed: [results[(seed, a, name)] for a in ACTIONS]
                                                       for seed in args.seeds})
            further = next_alpha(tried[name], best, grid)
            if further is not None:
                tried[name].add(further)
                grown = True
        if not grown:
            break

    print(f"Guidance step size per variant ({args.scale}; 16 training conditions per action, best of "
          f"{args.n_samples} by the final objective; seeds {', '.join(map(str, args.seeds))})\n")
    summary = {}
    for name in variants:
        table = {}
        for seed in args.seeds:
            for a in ACTIONS:
                table[(f"seed {seed}", a)] = evaluation.pooled_skeleton_medians([results[(seed, a, name)]])
            table[(f"seed {seed}", "pooled")] = evaluation.pooled_skeleton_medians([results[(seed, a, name)] for a in ACTIONS])
        every = [results[(seed, a, name)] for seed in args.seeds for a in ACTIONS]
        table[("all seeds", "pooled")] = evaluation.pooled_skeleton_medians(every)
        by_seed = {seed: [results[(seed, a, name)] for a in ACTIONS] for seed in args.seeds}
        table[("all seeds", "worst")] = evaluation.worst_seed_skeleton_medians(by_seed)
        table = pd.DataFrame(table)
        table.index.name = "α"
        alphas = sorted(tried[name])
        chosen = {f"seed {seed}": evaluation.chosen_alpha([results[(seed, a, name)] for a in ACTIONS])
                  for seed in args.seeds}
        worst = evaluation.chosen_alpha_over_seeds(by_seed)
        summary[name] = {**chosen, "worst seed": worst, "bracketed": alphas[0] < worst < alphas[-1],
                         "every seed pooled": evaluation.chosen_alpha(every), "library": library[name]}
        print(f"== {name}: median skeleton distance (m) of the kept sample")
        print(table.round(3).to_string(), "\n")
    print("== The chosen α per variant (each seed's; by the worst seed, the protocol's choice, bracketed when a worse "
          "α was tried on each side; every seed pooled, for comparison)")
    print(pd.DataFrame(summary).T.to_string())
    return 0


if __name__ == "__main__":
    sys.exit(main())
