"""Time one CHOICE trajectory plan (§4.2): the latent fit of Eq. 9 (100 steps, three initialisations
batched), the start point, the integration and the orientation transfer, on a test case at `toy`.
Reported, never asserted: CHOICE plans in about 1.25 s on an RTX 4090 (§8.1); the target here is
≤ 1.25 s on 2 CPU cores.

    python scripts/bench_choice_planner.py [--cases 10] [--threads 2]
"""
from __future__ import annotations

import argparse
import time

import numpy as np
import torch

from hoi_tutorial.choice.planner import interactions, intp, table3


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=10)
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    data_config = interactions.planner_data_config("toy")
    config = intp.planner_config("toy")
    train = interactions.interaction_set(data_config, "train")
    test = interactions.interaction_set(data_config, "test")
    model = intp.trained_planner(data_config, config).model
    cases = table3.planning_cases(test, data_config.field, reshape=False)[: args.cases]
    fits, totals = [], []
    for case in cases:
        start = time.perf_counter()
        plans = intp.plan_each_init(model, config, train, case.scene, case.condition, case.start, case.goal,
                                       inits=range(config.inits))
        totals.append(time.perf_counter() - start)
        fits.append(plans[0].fit.seconds)
    print(f"{len(cases)} plans, {config.fit_steps} latent steps x {config.inits} initialisations, "
          f"{args.threads} threads: median {np.median(totals):.3f} s per plan with all three paths "
          f"(latent fit {np.median(fits):.3f} s); CHOICE: 1.25 s on an RTX 4090")


if __name__ == "__main__":
    main()
