"""Choose the guidance step size α of each NIFTY guidance variant by one protocol, and measure the last step.

NIFTY does not state α (Eq. 4). Every variant the chapters guide with -- the offset field (NIFTY), the distance
field (Table 2), the non-parametric nearest anchor (Table 3), the 5-frame field (Table 6) and the human-frame field
(Table 7) -- gets its α from the same protocol, on training conditions, never on the test scenes
(``nifty.evaluation.guidance_alpha_sweep`` and ``chosen_alpha``): one guided sample for each of the 16 training
conditions per action, for α in ``ALPHA_GRID``; the α with the lowest median skeleton distance, sit and lift pooled.
It prints every α's numbers, the chosen α beside the one the library uses, and, for the offset field at its α, what
guiding the last denoising step too (k = 0, which the Trace and Pace code skips) changes on the same conditions.

It measures and never gates (exit code 0). Models, fields and sweeps are built or loaded from the artifact cache
(``$HOI_CACHE``), one per CPU core.

    python scripts/choose_guidance_alpha.py            # toy, seed 0 (the seed the library's values come from)
    python scripts/choose_guidance_alpha.py --seed 1
"""
import argparse
import functools
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from hoi_tutorial import intervals  # noqa: E402
from hoi_tutorial.infra import warm_cache  # noqa: E402
from hoi_tutorial.nifty import data, evaluation  # noqa: E402
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


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scale", default="toy")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    pd.set_option("display.width", 160)
    data_configs = {a: data.synthetic_data_config(a, args.scale, seed=args.seed) for a in ACTIONS}
    model_configs = {a: mm.motion_model_config(a, args.scale, seed=args.seed) for a in ACTIONS}
    eval_config = evaluation.evaluation_config(args.scale, seed=args.seed)
    field_configs = {(a, name): None if overrides is None else
                     fields.interaction_field_config(a, args.scale, seed=args.seed, **overrides)
                     for a in ACTIONS for name, (overrides, _) in VARIANTS.items()}
    offset_alpha = field_configs[(ACTIONS[0], "offset (NIFTY)")].alpha
    sweep_kwargs = {**{(a, name): dict(alphas=evaluation.ALPHA_GRID, objective=objective)
                       for name, (_, objective) in VARIANTS.items() for a in ACTIONS},
                    **{(a, every): dict(alphas=(offset_alpha,), guide_last_step=every)
                       for a in ACTIONS for every in (False, True)}}

    def field_of(key):
        action, name = key
        return field_configs[(action, "offset (NIFTY)" if isinstance(name, bool) else name)]

    def call(key, builder):
        return functools.partial(builder, data_configs[key[0]], model_configs[key[0]], field_of(key), eval_config,
                                 **sweep_kwargs[key])

    # Built one per core (infra.warm_cache): the models and their evaluations first (every variant shares them),
    # then one sweep per field (each trains its field), then the last-step pair; then everything loads.
    warm_cache([functools.partial(evaluation.build_evaluation, data_configs[a], model_configs[a], eval_config)
                for a in ACTIONS])
    grid = [key for key in sweep_kwargs if not isinstance(key[1], bool)]
    warm_cache([call(key, evaluation.build_alpha_sweep) for key in grid])
    warm_cache([call(key, evaluation.build_alpha_sweep) for key in sweep_kwargs if key not in grid])
    datasets = {a: data.synthesize(data_configs[a], progress=False) for a in ACTIONS}
    results = {key: evaluation.guidance_alpha_sweep(datasets[key[0]], model_configs[key[0]], field_of(key),
                                                    eval_config, **kw) for key, kw in sweep_kwargs.items()}
    sweeps = {key: results[key] for key in grid}
    last = {key: results[key] for key in sweep_kwargs if key not in grid}

    print(f"Guidance step size per variant ({args.scale}, seed {args.seed}; 16 training conditions per action, "
          "one guided sample each)\n")
    for name, (overrides, objective) in VARIANTS.items():
        table = pd.concat({a: pd.DataFrame(sweeps[(a, name)].summary()).T for a in ACTIONS}, axis=1)
        table[("pooled", "skeleton distance (m, median)")] = [
            float(np.median(np.concatenate([sweeps[(a, name)].scores[alpha].skeleton_distance for a in ACTIONS])))
            for alpha in evaluation.ALPHA_GRID]
        table.index.name = "α"
        chosen = evaluation.chosen_alpha([sweeps[(a, name)] for a in ACTIONS])
        used = evaluation.default_alpha(field_configs[(ACTIONS[0], name)], VARIANTS[name][1])
        print(f"== {name}: the protocol chooses α = {chosen:g}; the library uses α = {used:g}")
        print(table.round(3).to_string(), "\n")

    print(f"== The last denoising step (offset field, α = {offset_alpha:g}): guided from k = K-1 down to 1 "
          "(Trace and Pace) or down to 0 (every step)")
    for a in ACTIONS:
        skip, every = last[(a, False)], last[(a, True)]
        s, e = skip.scores[offset_alpha], every.scores[offset_alpha]
        diff = intervals.paired_difference(e.skeleton_distance, s.skeleton_distance)
        print(f"{a}: G median {np.median(skip.objective[offset_alpha]):.3f} -> "
              f"{np.median(every.objective[offset_alpha]):.3f} m²; skeleton distance median "
              f"{np.median(s.skeleton_distance):.3f} -> {np.median(e.skeleton_distance):.3f} m "
              f"(every step minus skipping, mean {diff.format(unit='m')}, {diff.n} conditions: "
              f"{diff.verdict('below')}); D2O ≤ 2 cm {int((s.d2o <= 0.02).sum())} -> {int((e.d2o <= 0.02).sum())} "
              f"of {len(s.d2o)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
