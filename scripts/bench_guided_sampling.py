"""Time NIFTY's guided sampling at the batch the chapters use: one block of ``GUIDED_SCENE_BLOCK`` test
conditions × N = 10 guided candidates (the preset's diffusion steps, the field's gradient through the denoiser at
every step but the last, best-of-N at the end), and the same batch unguided. Reports samples per second.

It measures and never gates (exit code 0). The motion model and the field are trained (or loaded from the
artifact cache, ``$HOI_CACHE``) first; only the sampling is timed, after one warm-up call.

    python scripts/bench_guided_sampling.py                  # toy, seed 0, 3 timed repeats
    python scripts/bench_guided_sampling.py --scenes 1       # one scene, 10 candidates
    python scripts/bench_guided_sampling.py --threads 2      # lend both cores (infra.threads_allowed)
"""
import argparse
import functools
import os
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import torch  # noqa: E402

from hoi_tutorial.infra import threads_allowed  # noqa: E402
from hoi_tutorial.nifty import data, evaluation, guidance, interaction_field, motion_model  # noqa: E402


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scale", default="toy")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--samples", type=int, default=10)
    parser.add_argument("--scenes", type=int, default=evaluation.GUIDED_SCENE_BLOCK,
                        help="conditions sampled at once (default: one of the chapters' blocks)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--threads", type=int, default=1,
                        help="torch threads for the sampling (the library's default is one)")
    args = parser.parse_args(argv)

    data_config = data.synthetic_data_config("sit", args.scale, seed=args.seed)
    model_config = motion_model.motion_model_config("sit", args.scale, seed=args.seed)
    field_config = interaction_field.interaction_field_config("sit", args.scale, seed=args.seed)
    dataset = data.synthesize(data_config, progress=False)
    model = motion_model.trained_motion_model(dataset, model_config, progress=False).model
    field = interaction_field.trained_interaction_field(dataset, model_config, field_config).model
    tensors = motion_model.InteractionTensors.from_sequences(dataset.sequences[:args.scenes], model_config.max_frames,
                                                             model_config.n_points, model_config.seed)
    cond = tensors.condition()
    rows = len(tensors) * args.samples
    print(f"{len(tensors)} sit conditions × {args.samples} candidates = {rows} samples per call, "
          f"K = {model_config.diffusion_steps} steps, SCALE={args.scale}, {os.cpu_count()} CPU cores, "
          f"{args.threads} torch thread(s)")
    for label, alpha in (("guided", guidance.step_size(field_config)), ("unguided (α = 0)", 0.0)):
        def run():
            with threads_allowed(args.threads):
                return guidance.guided_samples(model, cond, functools.partial(guidance.field_objective, field),
                                               n_samples=args.samples, alpha=alpha,
                                               generator=torch.Generator().manual_seed(args.seed))

        run()  # warm-up
        times = []
        for _ in range(args.repeats):
            start = time.perf_counter()
            run()
            times.append(time.perf_counter() - start)
        median = statistics.median(times)
        print(f"{label}: median {median:.2f} s per call over {args.repeats} runs (min {min(times):.2f}, max "
              f"{max(times):.2f}): {rows / median:.1f} samples per second")
    return 0


if __name__ == "__main__":
    sys.exit(main())
