"""Time CHOICE's three fields (§4.1) for one scene: a toy-mocap reach onto a bottle on a shelf,
the target and obstacle distances and the time of arrival by fast marching, at each preset's
cell size. Reported, never asserted (CHOICE reports no field time; its planner takes 1.25 s per
plan on an RTX 4090, §8.1).

    python scripts/bench_choice_fields.py [--repeats 5]
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from hoi_tutorial.choice.planner import fields
from hoi_tutorial.world.mocap.grasping import reach_grasp
from hoi_tutorial.world.objects import make_object, object_from_description


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    motion = reach_grasp(make_object("bottle", 0), seed=0, pick_up=False)
    target = object_from_description(motion.meta["object"])
    shelf = object_from_description(motion.meta["support"])
    wrist = np.asarray(motion.joint(motion.meta["hand"] + "_wrist"))[: motion.meta["anchor_frame"] + 1]
    for scale in ("toy", "paper"):
        config = fields.field_config(scale)
        grid = fields.object_grid(target, config)
        times = {"SDFs + distances": [], "with time of arrival": []}
        for _ in range(args.repeats):
            start = time.perf_counter()
            fields.scene_fields(grid, target, [shelf], None, motion.fps, config)
            times["SDFs + distances"].append(time.perf_counter() - start)
            start = time.perf_counter()
            fields.scene_fields(grid, target, [shelf], wrist, motion.fps, config)
            times["with time of arrival"].append(time.perf_counter() - start)
        parts = ", ".join(f"{k} {1000 * np.median(v):.0f} ms" for k, v in times.items())
        print(f"{scale:>5}: {grid.n}^3 cells of {100 * grid.spacing:.1f} cm: {parts} (median of {args.repeats})")


if __name__ == "__main__":
    main()
