"""Time SAMP's grid A* (``hoi_tutorial.samp.planning.astar``) against ``networkx.astar_path`` on one graph.

A 200×200 grid (seeded): ~20 % random blocked cells plus walls with gaps, so the path is long and
winding; start and goal in opposite corners, both free and connected. networkx gets the equivalent
graph (8-connected, no corner cutting, weights 1 and √2, octile heuristic); building it is not timed.
Both costs are checked equal. It measures and never gates (exit code 0).

    python scripts/bench_astar.py                  # 200×200, seed 0, 5 timed repeats each
    python scripts/bench_astar.py --size 300 --repeats 3
"""
import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import networkx as nx  # noqa: E402
import numpy as np  # noqa: E402

from hoi_tutorial.samp import planning  # noqa: E402
from hoi_tutorial.samp.planning import astar, path_cost  # noqa: E402


def make_grid(size, seed, density=0.2):
    """(size, size) bool grid: random obstacles plus vertical walls with one or two gaps each."""
    rng = np.random.default_rng(seed)
    blocked = rng.random((size, size)) < density
    for col in range(size // 5, size - 10, size // 5):
        blocked[:, col:col + 2] = True
        for gap in rng.choice(size - 6, size=2, replace=False) + 3:
            blocked[gap - 2:gap + 2, col:col + 2] = False
    blocked[:3, :3] = blocked[-3:, -3:] = False
    return blocked


def timed(fn, repeats):
    times, out = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times), out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=200)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args(argv)

    blocked = make_grid(args.size, args.seed)
    start, goal = (0, 0), (args.size - 1, args.size - 1)
    graph = planning.networkx_grid_graph(blocked)
    if not nx.has_path(graph, start, goal):
        print(f"seed {args.seed}: start and goal are not connected; try another seed")
        return 0

    ours_s, ours = timed(lambda: astar(blocked, start, goal), args.repeats)
    nx_s, theirs = timed(lambda: nx.astar_path(graph, start, goal, heuristic=planning.grid_distance, weight="weight"), args.repeats)
    ours_cost, nx_cost = path_cost(ours), path_cost(theirs)
    print(f"{args.size}×{args.size} grid, {blocked.mean():.0%} blocked, corner to corner, seed {args.seed}: "
          f"path of {len(ours)} cells, cost {ours_cost:.6f} (networkx {nx_cost:.6f}, "
          f"{'equal' if abs(ours_cost - nx_cost) < 1e-9 else 'DIFFERENT'})")
    print(f"median over {args.repeats} runs: ours {ours_s * 1e3:.1f} ms, networkx.astar_path {nx_s * 1e3:.1f} ms, "
          f"networkx / ours = {nx_s / ours_s:.1f}×")
    return 0


if __name__ == "__main__":
    sys.exit(main())
