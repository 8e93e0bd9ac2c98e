"""Time CHOICE's goal-phase Kalman filter (§5.2, Algorithm 1) batched over characters × channels
against filterpy's ``KalmanFilter`` looped over the same sequences, and check that they agree.
Reported, never asserted (CHOICE runs its filter once per frame inside a real-time controller).

    python scripts/bench_choice_kalman.py [--characters 1000] [--channels 4] [--frames 120] [--repeats 3]
"""
from __future__ import annotations

import argparse
import time

import numpy as np
from filterpy.kalman import KalmanFilter

from hoi_tutorial.choice.controller import kalman

PHASE = kalman.PHASE


def toy_measurements(rng, frames, characters, channels, config):
    """``(predicted, matched, deviations, use_matched, variance)`` of :func:`kalman.synthetic_goal_phases`."""
    seq = kalman.synthetic_goal_phases(rng, frames, characters, channels, config)
    return seq.predicted, seq.matched, seq.deviations, seq.use_matched, seq.variance


def wrapped(x):
    out = x.copy()
    out[..., PHASE] = kalman.wrap_phase(x[..., PHASE])
    return out


def run_filterpy(predicted, matched, deviations, use_matched, Q, config):
    """filterpy's KalmanFilter, one sequence at a time: (T, characters, channels, 3) and (..., 3, 3)."""
    frames, characters, channels, _ = predicted.shape
    states, covariances = np.empty_like(predicted), np.empty(predicted.shape + (3,))
    for i in range(characters):
        for k in range(channels):
            kf = KalmanFilter(dim_x=3, dim_z=3)
            kf.x, kf.P, kf.Q = np.zeros(3), np.zeros((3, 3)), Q
            kf.F, kf.H = kalman.transition_matrix(config.dt), np.eye(3)
            for t in range(frames):
                kf.predict()
                kf.update(predicted[t, i, k], R=deviations[t, i, 0] * Q)
                if use_matched[t, i, 0]:
                    kf.update(matched[t, i, k], R=Q)
                states[t, i, k], covariances[t, i, k] = kf.x, kf.P
    return states, covariances


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--characters", type=int, default=1000)
    parser.add_argument("--channels", type=int, default=4)
    parser.add_argument("--frames", type=int, default=120)
    parser.add_argument("--repeats", type=int, default=3, help="repeats of the batched filter (filterpy runs once)")
    args = parser.parse_args()
    config = kalman.PhaseFilterConfig()
    predicted, matched, deviations, use_matched, variance = toy_measurements(
        np.random.default_rng(0), args.frames, args.characters, args.channels, config)
    sequences = args.characters * args.channels

    times = []
    for _ in range(args.repeats):
        start = time.perf_counter()
        states, covariances = kalman.filter_sequence(variance, wrapped(predicted), deviations, config,
                                                     matched_goals=wrapped(matched), use_matched=use_matched)
        times.append(time.perf_counter() - start)
    batched = float(np.median(times))

    start = time.perf_counter()
    ref_states, ref_covariances = run_filterpy(predicted, matched, deviations, use_matched,
                                               kalman.process_noise(variance, config), config)
    looped = time.perf_counter() - start

    phase_error = np.abs(kalman.phase_difference(states[..., PHASE], ref_states[..., PHASE])).max()
    other_error = np.abs(states[..., 1:] - ref_states[..., 1:]).max()
    covariance_error = np.abs(covariances - ref_covariances).max()
    print(f"{sequences} sequences ({args.characters} characters x {args.channels} channels) x {args.frames} frames, "
          f"matched measurement on {use_matched.mean():.0%} of frames")
    print(f"  batched numpy filter: {batched:.3f} s (median of {args.repeats})")
    print(f"  filterpy, looped:     {looped:.3f} s")
    print(f"  speed-up:             {looped / batched:.0f}x")
    print(f"  max |difference|: phase (on the circle) {phase_error:.1e}, amplitude/frequency {other_error:.1e}, "
          f"covariance {covariance_error:.1e}")


if __name__ == "__main__":
    main()
