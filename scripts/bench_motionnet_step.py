"""Time one MotionNet step at run time: batch 1, CPU, the decoder only (SAMP §3.1, "at test time, we
only utilize the decoder"), plus the work of the run-time loop around it (the root update, the
goal features and the voxels seen from the new root), and their ratio. The two are timed in turn,
five rounds each, and the medians compared.

The weights are freshly initialised (speed does not depend on training); sizes are the ``toy``
preset's unless ``--scale`` says otherwise. It measures and never gates (exit code 0). The target
is 300 steps/s, ten times the paper's 30 fps real time.

    python scripts/bench_motionnet_step.py                  # toy sizes, 1 thread, 2000 steps
    python scripts/bench_motionnet_step.py --scale paper --threads 2
"""
import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import torch  # noqa: E402

from hoi_tutorial.infra import threads_allowed  # noqa: E402
from hoi_tutorial.samp import motionnet, runtime  # noqa: E402
from hoi_tutorial.samp.motion_data import object_voxel_cells  # noqa: E402
from hoi_tutorial.world.objects import make_object  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scale", default="toy", choices=("toy", "small", "paper"))
    parser.add_argument("--model", default="samp", choices=motionnet.MODEL_KINDS)
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    config = motionnet.motionnet_config(args.scale, model=args.model)
    model = motionnet.build_motion_model(config).eval()
    centres, occupancy = (torch.as_tensor(a)[None] for a in object_voxel_cells(make_object("chair", seed=0)))
    goals = runtime.GoalSequence.single([[0.0, 0.0, 0.5]], [[0.0, 1.0, 0.0]], ["sit"])
    start, roots = runtime.standing_state(), torch.tensor([[0.0, 3.0, 3.1]])
    generator = torch.Generator().manual_seed(0)
    runtime.rollout(model, start, roots, goals, 50, generator, centres, occupancy)  # warm-up
    x, v = start[None], torch.zeros(1, 2048)
    z = torch.zeros(1, model.latent) if model.latent else None
    # the two measured in turn, in rounds, so that both see the same machine state; medians reported
    rounds, per_round = 5, max(args.steps // 5, 1)
    step_times, decoder_times = [], []
    with threads_allowed(args.threads), torch.no_grad():
        for _ in range(rounds):
            t0 = time.perf_counter()
            runtime.rollout(model, start, roots, goals, per_round, generator, centres, occupancy)
            step_times.append((time.perf_counter() - t0) / per_round)
            t0 = time.perf_counter()
            for _ in range(per_round):  # the decoder alone, without the loop's bookkeeping
                model.predict(x, v, z)
            decoder_times.append((time.perf_counter() - t0) / per_round)
    step, decoder = statistics.median(step_times), statistics.median(decoder_times)
    n_params = sum(p.numel() for p in model.parameters())
    print(f"MotionNet ({args.model}, {args.scale} sizes, {n_params / 1e6:.2f} M parameters), batch 1, "
          f"{args.threads} thread(s):")
    print(f"  full run-time step: {1 / step:8.0f} steps/s ({1e3 * step:.2f} ms)")
    print(f"  decoder alone:      {1 / decoder:8.0f} steps/s ({1e3 * decoder:.2f} ms)")
    print(f"  step / decoder:     {step / decoder:8.2f}  (target: at most 2; the loop around the network "
          f"costs {1e3 * (step - decoder):.2f} ms)")
    print("  target: 300 steps/s (10x the paper's 30 fps)")


if __name__ == "__main__":
    main()
