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
import concurrent.futures
import multiprocessing
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from hoi_tutorial import intervals  # noqa: E402
from hoi_tutorial.infra import available_cores  # noqa: E402
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


def _configs(action, scale, seed, overrides):
    field = None if overrides is None else fields.interaction_field_config(action, scale, seed=seed, **overrides)
    return (data.synthetic_data_config(action, scale, seed=seed), mm.motion_model_config(action, scale, seed=seed),
            field, evaluation.evaluation_config(scale, seed=seed))


def _prepare(action, scale, seed, overrides):
    data_config, model_config, field_config, eval_config = _configs(action, scale, seed, overrides)
    dataset = data.synthesize(data_config, progress=False)
    evaluation.evaluate_motion_model(dataset, model_config, eval_config)
    if field_config is not None:
        fields.trained_interaction_field(dataset, model_config, field_config)


def _sweep(action, scale, seed, overrides, objective, alphas, guide_last_step):
    data_config, model_config, field_config, eval_config = _configs(action, scale, seed, overrides)
    dataset = data.synthesize(data_config, progress=False)
    return evaluation.guidance_alpha_sweep(dataset, model_config, field_config, eval_config, alphas=alphas,
                                           objective=objective, guide_last_step=guide_last_step)


def _one_thread():
    import torch
    torch.set_num_threads(1)  # one worker per core, one thread each (as infra.warm_cache's workers)


def _run_all(pool, function, jobs):
    futures = {key: pool.submit(function, *args) for key, args in jobs.items()}
    return {key: future.result() for key, future in futures.items()}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scale", default="toy")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    pd.set_option("display.width", 160)
    context = multiprocessing.get_context("spawn")
    with concurrent.futures.ProcessPoolExecutor(available_cores(), mp_context=context, initializer=_one_thread) as pool:
        # The data and motion models first (every variant shares them), then the fields, then the sweeps.
        _run_all(pool, _prepare, {a: (a, args.scale, args.seed, None) for a in ACTIONS})
        _run_all(pool, _prepare, {(a, name): (a, args.scale, args.seed, overrides) for a in ACTIONS
                                  for name, (overrides, _) in VARIANTS.items() if overrides is not None})
        sweeps = _run_all(pool, _sweep, {(a, name): (a, args.scale, args.seed, overrides, objective,
                                                     evaluation.ALPHA_GRID, False)
                                         for name, (overrides, objective) in VARIANTS.items() for a in ACTIONS})
        offset_alpha = fields.interaction_field_config("sit", args.scale, seed=args.seed).alpha
        last = _run_all(pool, _sweep, {(a, flag): (a, args.scale, args.seed, {}, "field", (offset_alpha,), flag)
                                       for a in ACTIONS for flag in (False, True)})

    print(f"Guidance step size per variant ({args.scale}, seed {args.seed}; 16 training conditions per action, "
          "one guided sample each)\n")
    for name, (overrides, objective) in VARIANTS.items():
        table = pd.concat({a: pd.DataFrame(sweeps[(a, name)].summary()).T for a in ACTIONS}, axis=1)
        table[("pooled", "skeleton distance (m, median)")] = [
            float(np.median(np.concatenate([sweeps[(a, name)].scores[alpha].skeleton_distance for a in ACTIONS])))
            for alpha in evaluation.ALPHA_GRID]
        table.index.name = "α"
        chosen = evaluation.chosen_alpha([sweeps[(a, name)] for a in ACTIONS])
        used = (guidance.GUIDANCE_ALPHA["nearest_anchor"] if overrides is None else
                fields.interaction_field_config("sit", args.scale, seed=args.seed, **overrides).alpha)
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
