"""Train each of the library's trainers for a few steps on one device: a smoke test of the CUDA paths.

On a GPU a trainer must keep its data set where it indexes it and move what the network reads to the
network's device; a tensor left on (or made on) the CPU fails on the first CUDA step, and only there.
Each check trains one model on tiny data (a few toy clips, objects or interactions; small networks)
for ``--steps`` steps and checks that the losses are finite and that the model's parameters and
buffers are on the device. It prints ``name: ok (...)`` or ``name: FAILED <type>: <message>`` and the
end of the traceback, then a summary; the exit code is 1 when a check failed.

    python scripts/cuda_smoke.py                                  # every check, on cuda
    python scripts/cuda_smoke.py --only prior,motionnet_samp      # some of them
    python scripts/cuda_smoke.py --device cpu --steps 2           # the same checks on the CPU

The artifact cache is a fresh temporary folder (``HOI_CACHE`` is set to it), so the cached wrapper
always trains and no other cache is touched. The checks call the ``train_*`` functions behind the
``trained_*`` wrappers (chapters in brackets):

    toy2d, trajectory      nifty.toy2d, nifty.trajectories denoisers (02)
    prior                  nifty.motion_prior.train_reverse_prior, what nifty.data.trained_prior and
                           synthesize train (03-05)
    motion_model, cond_vae nifty.motion_model.train_motion_model (04-05), nifty.baselines.train_cond_vae (06)
    interaction_field      nifty.interaction_field.field_training_pairs (an untrained motion model) and
                           train_interaction_field (05)
    goalnet                samp.goalnet.train_goalnet (11)
    motionnet_*            samp.motionnet.train_motion_model: MotionNet, the NSM-like and MLP models, own
                           inputs as the public code (12-14); own predictions from the start, one epoch
                           whose batch size gives about --steps steps
    planner, diffusion_policy, phase, controller
                           choice.planner.intp, choice.planner.baselines, choice.controller.phase,
                           choice.controller.network (16-19); the controller on an untrained PAE
    controller_cached      choice.controller.network.trained_controller, the one wrapper called: it trains its PAE
                           too, and the model it returns must be wholly on the CPU
"""
import argparse
import functools
import math
import os
import sys
import tempfile
import time
import traceback
from pathlib import Path
from types import SimpleNamespace

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import torch  # noqa: E402

from hoi_tutorial.choice.controller import network, phase as ph  # noqa: E402
from hoi_tutorial.choice.planner import baselines as choice_baselines, interactions as choice_interactions  # noqa: E402
from hoi_tutorial.choice.planner import intp as pl  # noqa: E402
from hoi_tutorial.nifty import baselines as nifty_baselines, interaction_field as inf, motion_model as mm  # noqa: E402
from hoi_tutorial.nifty import motion_prior as mp, toy2d as t2, trajectories as tj  # noqa: E402
from hoi_tutorial.samp import goalnet as gn, motion_data as md, motionnet as mn  # noqa: E402
from hoi_tutorial.world import mocap  # noqa: E402
from hoi_tutorial.world.objects.toy_object import object_from_description  # noqa: E402

CHECKS = {}  # name -> (function(device, steps) -> (model, result with .losses), returns a CPU model by design)


def check(name, cached=False):
    def register(function):
        CHECKS[name] = (function, cached)
        return function
    return register


def _sit_tensors():
    """Two toy sitting clips with their chairs, as the NIFTY models' training tensors (31 frames, 64 points)."""
    clips = mocap.generate_dataset(2, seed=0, kinds=("sit",))
    records = [SimpleNamespace(motion=c, obj=object_from_description(c.meta["object"])) for c in clips]
    return mm.InteractionTensors.from_sequences(records, max_frames=31, n_points=64)


NIFTY_SIZES = {"max_frames": 31, "n_points": 64, "width": 32, "layers": 1, "heads": 2, "pointnet_hidden": (16, 32),
               "batch_size": 4, "warmup_steps": 0}


@check("toy2d")
def toy2d(device, steps):
    config = t2.toy2d_config(steps=steps, n_train=256, batch_size=32, width=32, depth=1, warmup_steps=0)
    return t2.train_toy2d_denoiser(config, device=device)


@check("trajectory")
def trajectory(device, steps):
    walks = tj.make_walk_trajectories(tj.walk_data_config(n_clips=4))
    config = tj.trajectory_model_config(steps=steps, batch_size=8, width=32, depth=1, warmup_steps=0)
    model, _, result = tj.train_trajectory_denoiser(config, walks, device=device)
    return model, result


@check("prior")
def prior(device, steps):
    clips = mocap.generate_dataset(1, seed=0, kinds=("walk", "sit"))
    config = mp.prior_config(steps=steps, width=32, latent=4, batch_size=8)  # own predictions after steps // 3
    return mp.train_reverse_prior(clips, config, device=device, progress=False)


@check("motion_model")
def motion_model(device, steps):
    config = mm.motion_model_config("sit", steps=steps, diffusion_steps=10, **NIFTY_SIZES)
    return mm.train_motion_model(_sit_tensors(), config, device=device)


@check("interaction_field")
def interaction_field(device, steps):
    tensors = _sit_tensors()
    model = mm.build_motion_model(mm.motion_model_config("sit", diffusion_steps=10, **NIFTY_SIZES),
                                  *tensors.normalisation())
    config = inf.interaction_field_config("sit", steps=steps, copies_per_sequence=2, width=32, layers=1, heads=2,
                                          pointnet_hidden=(16, 32), batch_size=4)
    pairs = inf.field_training_pairs(model, tensors, config, device=device)
    return inf.train_interaction_field(pairs, config, device=device)


@check("cond_vae")
def cond_vae(device, steps):
    config = nifty_baselines.cond_vae_config("sit", steps=steps, latent=4, **NIFTY_SIZES)
    return nifty_baselines.train_cond_vae(_sit_tensors(), config, device=device)


@check("goalnet")
def goalnet(device, steps):
    data = gn.goal_data(gn.goal_data_config(instances=(("chair", 1), ("sofa", 1)), scalings=2), "train")
    config = gn.goalnet_config(steps=steps, kl_warmup=steps, batch_size=8, interaction_hidden=(32, 32),
                               interaction_out=8)
    return gn.train_goalnet(data, config, device=device)


def _motionnet(device, steps, **overrides):
    data = md.motion_data(md.motion_data_config(clips=(("walk", 1), ("sit", 1)), test_clips=1), "train")
    windows = len(data.windows(8))
    values = {"state_hidden": (32, 16, 16), "interaction_hidden": (16, 16), "interaction_out": 8,
              "gating_hidden": (16, 8), "prediction_hidden": 32, "n_experts": 3, "latent": 4, "mlp_hidden": (32, 32),
              "rollout": 8, "epochs": 1, "steps": None, "c1": 0.0, "c2": 0.5,
              "batch_size": math.ceil(windows / steps)}
    model, result = mn.train_motion_model(data, mn.motionnet_config(**{**values, **overrides}), device=device)
    if set(result.extra["teacher_forcing"]) != {0.0}:
        raise AssertionError("expected own-prediction inputs (P = 0) at every step")
    return model, result


MOTIONNET_VARIANTS = {"motionnet_samp": {}, "motionnet_nsm": {"model": "nsm"}, "motionnet_mlp": {"model": "mlp"},
                      "motionnet_ground_truth": {"own_inputs": "ground_truth"}}
for variant, overrides in MOTIONNET_VARIANTS.items():
    check(variant)(functools.partial(_motionnet, **overrides))


def _interactions():
    return choice_interactions.interaction_set(choice_interactions.planner_data_config(n_clips=1, n_test_clips=1), "train")


@check("planner")
def planner(device, steps):
    config = pl.planner_config(steps=steps, latent=8, width=32, points=64, batch_size=4)
    return pl.train_planner(_interactions(), config, device=device)


@check("diffusion_policy")
def diffusion_policy(device, steps):
    config = choice_baselines.diffusion_policy_config(steps=steps, batch_size=32, width=32, depth=1, diffusion_steps=10)
    return choice_baselines.train_diffusion_policy(_interactions(), config, device=device)


@check("phase")
def phase(device, steps):
    config = ph.phase_config(steps=steps, batch_size=16)
    clips = mocap.generate_dataset(1, seed=0, kinds=config.kinds)
    windows = torch.cat([ph.clip_windows(ph.motion_curves(c), config.window_frames, config.frame_step) for c in clips])
    return ph.train_phase_autoencoder(windows, config, device=device)


CONTROLLER_SIZES = {"hidden": 32, "gating_hidden": 16, "n_experts": 2, "batch_size": 8, "unroll": 3}


@check("controller")
def controller(device, steps):
    pae = ph.build_phase_autoencoder(ph.phase_config()).eval()
    config = network.controller_config(clips=2, steps=steps, unroll_steps=steps // 2, **CONTROLLER_SIZES)
    return network.train_controller(network.controller_data(config, pae), config, pae, device=device)


@check("controller_cached", cached=True)
def controller_cached(device, steps):
    config = network.controller_config(clips=1, steps=steps, unroll_steps=steps // 2, phase_steps=steps, **CONTROLLER_SIZES)
    trained = network.trained_controller(config, device=device)
    return trained.model, trained  # a TrainedModel, which has .losses too


def _misplaced(model, device):
    """Names of the parameters and buffers not on ``device`` (an index is compared only when given)."""
    return [f"{name} on {t.device}" for name, t in [*model.named_parameters(), *model.named_buffers()]
            if t.device.type != device.type or (device.index is not None and t.device.index != device.index)]


def run(name, device, steps):
    function, cached = CHECKS[name]
    start = time.perf_counter()
    try:
        model, result = function(str(device), steps)
        if device.type == "cuda":
            torch.cuda.synchronize(device)  # a kernel's error surfaces in the check that launched it
        losses = [float(v) for v in result.losses]
        if not losses or not all(math.isfinite(v) for v in losses):
            raise AssertionError(f"expected finite losses, got {losses}")
        expected = torch.device("cpu") if cached else device
        misplaced = _misplaced(model, expected)
        if misplaced:
            raise AssertionError(f"{len(misplaced)} tensors not on {expected}: " + ", ".join(misplaced[:5]))
        where = "cpu (a cached wrapper: its model comes back on the CPU by design)" if cached else str(device)
        print(f"{name}: ok ({time.perf_counter() - start:.1f} s, final loss {losses[-1]:.4g}, parameters on {where})",
              flush=True)
        return True
    except Exception as error:  # noqa: BLE001 - every failure is reported, then the next check runs
        print(f"{name}: FAILED {type(error).__name__}: {error}", flush=True)
        for line in "".join(traceback.format_exception(error)).rstrip().splitlines()[-12:]:
            print(f"    {line}", flush=True)
        return False


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--device", default="cuda", help="cuda, cuda:N or cpu (default: cuda)")
    parser.add_argument("--only", default="", help="comma-separated check names (default: all)")
    parser.add_argument("--steps", type=int, default=4, help="optimiser steps per check (default: 4)")
    args = parser.parse_args()
    sys.stdout.reconfigure(line_buffering=True)  # the library's own lines ([cache] ...) through a pipe, in order
    device = torch.device(args.device)
    if device.type == "cuda" and not torch.cuda.is_available():
        sys.exit(f"cuda_smoke: device {args.device!r} was requested but CUDA is not available "
                 "(torch.cuda.is_available() is False); use --device cpu to run the checks on the CPU")
    names = [n.strip() for n in args.only.split(",") if n.strip()] or list(CHECKS)
    unknown = [n for n in names if n not in CHECKS]
    if unknown or args.steps < 2:
        sys.exit(f"cuda_smoke: unknown checks {unknown} (expected names from {', '.join(CHECKS)})" if unknown
                 else f"cuda_smoke: --steps must be at least 2, got {args.steps}")
    name_of = torch.cuda.get_device_name(device) if device.type == "cuda" else "CPU"
    print(f"cuda_smoke: torch {torch.__version__}, device {device} ({name_of}), {args.steps} steps per check",
          flush=True)
    with tempfile.TemporaryDirectory(prefix="hoi_smoke_") as folder:
        os.environ["HOI_CACHE"] = folder
        failed = [name for name in names if not run(name, device, args.steps)]
    print(f"cuda_smoke: {len(names) - len(failed)} of {len(names)} checks passed on {device}"
          + (f"; failed: {', '.join(failed)}" if failed else ""), flush=True)
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
