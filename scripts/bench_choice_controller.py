"""Time one step of CHOICE's goal-driven controller at run time with the Kalman-filtered goal phase
(§5.1–5.2, Algorithm 1): batch 1, CPU — the network, Eq. 14's blend, Eq. 22's deviation and one
``kalman.filter_step`` — as ``runtime.rollout`` runs it, frame after frame.

The weights are freshly initialised (speed does not depend on training); sizes are the ``toy``
preset's unless ``--scale`` says otherwise. It measures and never gates (exit code 0). The target is
600 steps/s, ten times the paper's 60 fps real time, and a step at most twice the network's forward
alone; the bench prints both ratios. The network inside the step runs slower than one forward after another
(the loop's other work between two forwards slows the next: its weights and branches leave the CPU's
caches), so the two ratios differ.

    python scripts/bench_choice_controller.py                  # toy sizes, 1 thread, 600 steps
    python scripts/bench_choice_controller.py --scale paper --threads 2 --variant none
"""
import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import torch  # noqa: E402

from hoi_tutorial.choice.controller import features, network as ctrl_network, phase, runtime  # noqa: E402
from hoi_tutorial.infra import threads_allowed  # noqa: E402
from hoi_tutorial.world import mocap  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scale", default="toy", choices=("toy", "small", "paper"))
    parser.add_argument("--variant", default="kalman", choices=features.VARIANTS)
    parser.add_argument("--steps", type=int, default=600)
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    config = ctrl_network.controller_config(args.scale)
    torch.manual_seed(0)
    pae = phase.build_phase_autoencoder(phase.phase_config(config.phase_scale)).eval()
    model = ctrl_network.build_controller(config, pae).eval()
    clip = mocap.generate_dataset(1, seed=0, kinds=("reach_grasp",))
    state, goal = runtime.initial_state(model, clip), runtime.clip_goal(model, clip)
    with threads_allowed(args.threads):
        timing = runtime.step_timing(model, state, goal, args.steps, args.variant)
    print(f"controller ({args.scale}, {sum(p.numel() for p in model.net.parameters()):,} parameters, "
          f"{args.threads} thread(s)), goal phase '{args.variant}', batch 1, {args.steps} steps")
    print(f"  whole step (network, FK, Eq. 14 blend, Eq. 22 deviation, Eqs. 15-16, filter): "
          f"{timing['steps_per_second']:6.0f} steps/s  ({timing['step_ms']:.3f} ms)")
    print(f"  the network alone, one forward after another:                         "
          f"{1e3 / timing['network_ms']:6.0f} steps/s  ({timing['network_ms']:.3f} ms)")
    print(f"  the network inside the step (a second rollout, timed around each forward): "
          f"{timing['network_in_step_ms']:.3f} ms")
    print(f"  step / network alone: {timing['ratio']:.1f}x   step / network inside the step: "
          f"{timing['ratio_in_step']:.1f}x   (CHOICE III's target: 2x the network alone)")
    print("  target: 600 steps/s (10x the paper's 60 fps)")


if __name__ == "__main__":
    main()
