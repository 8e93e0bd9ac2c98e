"""Time SAMP's grid A* (``hoi_tutorial.samp.planning.astar``) against ``networkx.astar_path`` on one graph.

A 200×200 grid (seeded): ~20 % random blocked cells plus walls with gaps, so the path is long and
winding; start and goal in opposite corners, both free and connected. networkx gets the equivalent
graph (8-connected, no corner cutting, weights 1 and √2, octile heuristic); building it is not timed.
Both costs are checked equal. It measures and never gates (exit code 0).

    python scripts/bench_astar.py                  # 200×200, seed 0, 5 timed repeats each
    python scripts/bench_astar.py --size 300 --repeats 3
"""
import argparse
import math
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import networkx as nx  # noqa: E402
import numpy as np  # noqa: E402

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


def grid_graph(blocked):
    """The 8-connected graph astar searches: no diagonal step past a blocked side cell."""
    H, W = blocked.shape
    graph = nx.Graph()
    free = [(i, j) for i in range(H) for j in range(W) if not blocked[i, j]]
    graph.add_nodes_from(free)
    for i, j in free:
        for di, dj in ((0, 1), (1, 0), (1, 1), (1, -1)):
            a, b = i + di, j + dj
            if not (0 <= a < H and 0 <= b < W) or blocked[a, b]:
                continue
            if di and dj and (blocked[i + di, j] or blocked[i, j + dj]):
                continue
            graph.add_edge((i, j), (a, b), weight=math.sqrt(2.0) if di and dj else 1.0)
    return graph


def octile(u, v):
    dx, dy = abs(u[0] - v[0]), abs(u[1] - v[1])
    return max(dx, dy) + (math.sqrt(2.0) - 1.0) * min(dx, dy)


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
    graph = grid_graph(blocked)
    if not nx.has_path(graph, start, goal):
        print(f"seed {args.seed}: start and goal are not connected; try another seed")
        return 0

    ours_s, ours = timed(lambda: astar(blocked, start, goal), args.repeats)
    nx_s, theirs = timed(lambda: nx.astar_path(graph, start, goal, heuristic=octile, weight="weight"), args.repeats)
    ours_cost, nx_cost = path_cost(ours), path_cost(theirs)
    print(f"{args.size}×{args.size} grid, {blocked.mean():.0%} blocked, corner to corner, seed {args.seed}: "
          f"path of {len(ours)} cells, cost {ours_cost:.6f} (networkx {nx_cost:.6f}, "
          f"{'equal' if abs(ours_cost - nx_cost) < 1e-9 else 'DIFFERENT'})")
    print(f"median over {args.repeats} runs: ours {ours_s * 1e3:.1f} ms, networkx.astar_path {nx_s * 1e3:.1f} ms, "
          f"networkx / ours = {nx_s / ours_s:.1f}×")
    return 0


if __name__ == "__main__":
    sys.exit(main())
