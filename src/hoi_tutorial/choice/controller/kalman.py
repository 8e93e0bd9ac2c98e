"""The phase linear dynamical system and the goal-phase Kalman filter (CHOICE §5.2, Eqs. 15–22,
Algorithm 1).

What the paper does. The controller works in DeepPhase's latent space: per phase channel the state
is ``X^p = [S, A, F]ᵀ`` — phase ``S`` (cycles, circular in [0, 1)), amplitude ``A`` (in [0, 1]) and
frequency ``F`` (Hz, in [0, F_m] with ``F_m`` the Nyquist frequency). CHOICE models the controller as
the linear dynamical system of Eqs. 15–17, ``X_{t+Δt} = A X_t + B U`` with ``A`` advancing the phase
by ``Δt·F``, ``B = diag(β, 1, 1)`` (``β = 0.5``) and the network's update ``U = [ΔS, ΔA, ΔF]ᵀ``,
approximately ``C (X_g − X_t)``. The *goal* phase ``G^p`` (the phase state of the next keyframe) is
not known at run time, so a Kalman filter tracks it (Algorithm 1): predict with ``F = A`` and
``Q = 0.2·diag(σ̄)`` (Eqs. 18–19, ``σ̄`` the dataset's variance of each state variable), then refine
with the network's goal-phase prediction, covariance ``R_pred = c·Q`` where ``c`` is the deviation
between the ego- and goal-centric key-joint predictions (Eqs. 21–22), and — when the root is near
its goal and the working hand is not — with the phase of the matched motion, covariance ``Q``.

What ours does. The same filter on numpy float64 arrays, batched over any leading dimensions
(characters × channels): state ``(..., 3)`` ordered ``[S, A, F]`` as the paper's ``X^p``, covariance
``(..., 3, 3)``. :func:`lds_step` is Eq. 15, :func:`linear_control` Eq. 17's approximation,
:func:`goal_phase_at` the goal state of Eqs. 15–16 frame by frame (below), :func:`predict` Eq. 18, :func:`update` one measurement of Eq. 20, :func:`filter_step` one pass of
Algorithm 1's loop, :func:`filter_sequence` the loop over frames and :func:`bidirectional_deviation`
Eq. 22. It works on ``[S, A, F]``; Eq. 13's features ``A·(cos 2πS, sin 2πS)`` are the PAE's
(``phase``). The filter equals ``filterpy.kalman.KalmanFilter`` with ``H = I`` to rounding (the tests
check it), up to the phase wrap below. Eq. 20 itself is missing from our copy of the paper; its gain
``K_m = P (P + R_m)⁻¹`` and Algorithm 1's update survive and are what :func:`update` runs.

Choices the paper does not state, ours:

- **One goal-phase model.** §5.2 makes the goal ``X_g^p`` a state of the same linear system as ``X_t^p`` (Eqs.
  15–17: the state "can be guided to converge toward the desired goal state"), the filter predicts it with the
  phase-advancing ``F`` of Eq. 19 and calls it "the time-varying goal state", whose estimate is "a continuous-time
  goal trajectory in the latent space that infills the interaction keyframes". We read the goal phase at frame
  ``t`` as the keyframe's phase state ``X^p_g`` (§5.1's ``(A_g, S_g, F_g)`` at frame ``g``) carried along the free
  dynamics to ``t``: ``X_g^p(t) = F^{t−g} X_g^p = [S_g − (g − t) Δt F_g, A_g, F_g]``, which reaches the keyframe's
  phase at ``g`` and advances by ``F`` every frame (:func:`goal_phase_at`). The training inputs and targets
  (``features.clip_features``), the matched measurement and the start of the filter (``runtime.rollout``) all
  take it from :func:`goal_phase_at`, so that the filter's prediction ``F G^p`` and its measurements agree on the
  goal phase of every frame. (Were a measurement held at the keyframe's phase while ``F`` advances the estimate, it
  would leave a steady bias however clean the measurement, about ``(1 − K) / K · Δt F`` cycles for a phase gain
  ``K``.)
- **Sequential updates.** Algorithm 1 writes the gain with the predicted ``P′`` and the innovation
  against the predicted ``G^{p′}`` inside its loop over measurements; read literally with two
  measurements it would count the prediction twice. We read it as Eq. 20's "refined iteratively with
  the individual measurements": each measurement's gain ``K = P (P + R)⁻¹`` and innovation use the
  estimate left by the one before (the standard sequential filter, filterpy's ``update`` called
  twice), network prediction first. The measurement model is ``H = I`` (``K`` of Eq. 20 has no ``H``),
  and the covariance update is the paper's ``P ← (I − K) P``.
- **The circular phase.** Innovations of ``S`` are wrapped to [−0.5, 0.5) and the estimate's phase
  wrapped to [0, 1) after each predict and update (§5.2: "the phase is circularly updated"); the
  amplitude and frequency of both the LDS state and the filter's estimate are clipped to [0, A_max]
  and [0, F_m] (the goal state is a state of the same LDS). Clipping moves the mean only; the
  covariance is the filter's.
- **The order of ``Q``.** Eq. 19 lists ``σ_s², σ_f², σ_a²`` while ``X^p`` is ``[S, A, F]``; we match
  the variances to the variables by name, ``Q = 0.2·diag(σ̄_S, σ̄_A, σ̄_F)``.
- **Eq. 22.** It sums over ``j = 0..3``, the four key joints of Eq. 14 (root, hip, two wrists), though
  the text says three; we sum over whatever joints are passed. ``‖log(r)‖_F`` is taken literally: the
  Frobenius norm of the skew matrix ``log r`` is ``√2·θ`` for a rotation by ``θ``. Its ``β`` (not the
  ``β = 0.5`` of Eq. 16) is ``1 / body_width``; the body width defaults to the mean toy body's rest
  shoulder-to-shoulder distance. The goal-centric prediction must first be mapped into the egocentric
  frame by Eq. 14, ``G^{keyJ} T^{inv}``; that is the caller's.
- **Nearby.** Algorithm 1's ``Nearby`` has no threshold in the paper; ours is a distance below
  ``nearby_radius`` (0.5 m, about a stride) for both the root and the hand.
- ``Δt = 1 / 30 s`` (the toy world's frame rate), so ``F_m = 15 Hz``; ``A_max = 1`` as §5.2 states.
  ``σ̄`` is an input (Algorithm 1's): which dataset statistic it is, is the caller's.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import NamedTuple, Optional

import numpy as np

from ..._validate import check_finite, check_numbers, check_shape
from ...world.motion import FPS
from ...world.skeleton import joint_index, rest_joint_positions

__all__ = [
    "STATE_NAMES",
    "PHASE",
    "AMPLITUDE",
    "FREQUENCY",
    "PhaseFilterConfig",
    "mean_body_width",
    "transition_matrix",
    "control_matrix",
    "wrap_phase",
    "phase_difference",
    "constrain",
    "lds_step",
    "linear_control",
    "goal_phase_at",
    "process_noise",
    "initial_goal_phase",
    "predict",
    "update",
    "bidirectional_deviation",
    "matched_measurement_active",
    "filter_step",
    "filter_sequence",
    "SyntheticGoalPhases",
    "synthetic_goal_phases",
]

# The phase state X^p = [S, A, F]ᵀ of §5.2, one per DeepPhase channel.
STATE_NAMES = ("phase", "amplitude", "frequency")
PHASE, AMPLITUDE, FREQUENCY = 0, 1, 2


# ----------------------------------------------------------------------------- configuration


@functools.lru_cache(maxsize=1)
def mean_body_width() -> float:
    """The mean toy body's rest shoulder-to-shoulder distance, metres (Eq. 22's body width, ours)."""
    joints = rest_joint_positions().numpy()
    return float(np.linalg.norm(joints[joint_index("left_shoulder")] - joints[joint_index("right_shoulder")]))


@dataclass(frozen=True)
class PhaseFilterConfig:
    """Constants of the phase LDS and the goal-phase Kalman filter.

    Attributes:
        dt: frame time ``Δt`` of Eqs. 16 and 19, seconds (ours: the toy world's 1/30 s).
        phase_blend: ``β`` of Eq. 16, the weight of the network's phase update (CHOICE: 0.5).
        amplitude_max: upper bound of the amplitude (CHOICE §5.2: 1).
        noise_scale: ``Q = noise_scale · diag(σ̄)`` (CHOICE Eqs. 19, 21: 0.2).
        rotation_weight: ``α`` of Eq. 22 (CHOICE: 1/π).
        body_width: Eq. 22's ``β = 1 / body_width``, metres; ``None``: :func:`mean_body_width` (ours).
        nearby_radius: Algorithm 1's ``Nearby`` threshold for the root and the hand, metres (ours).
    """

    dt: float = 1.0 / FPS
    phase_blend: float = 0.5
    amplitude_max: float = 1.0
    noise_scale: float = 0.2
    rotation_weight: float = 1.0 / np.pi
    body_width: Optional[float] = None
    nearby_radius: float = 0.5

    def __post_init__(self):
        for name in ("dt", "amplitude_max", "noise_scale", "nearby_radius"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or isinstance(value, bool) or not value > 0:
                raise ValueError(f"{name}: expected a positive number, got {value!r}")
        if not 0 < self.phase_blend <= 1:
            raise ValueError(f"phase_blend: expected β of Eq. 16 in (0, 1], got {self.phase_blend!r}")
        if not self.rotation_weight >= 0:
            raise ValueError(f"rotation_weight: expected α of Eq. 22 >= 0, got {self.rotation_weight!r}")
        if self.body_width is not None and not self.body_width > 0:
            raise ValueError(f"body_width: expected a positive number of metres or None, got {self.body_width!r}")
        check_numbers(self, ("rotation_weight",), at_least=0)
        check_numbers(self, ("body_width",), above=0, allow_none=True)

    @property
    def frequency_max(self) -> float:
        """``F_m``, the Nyquist frequency of the frame rate, Hz (CHOICE §5.2)."""
        return 0.5 / self.dt

    @property
    def position_weight(self) -> float:
        """Eq. 22's ``β``: one over the body width, 1/metres."""
        return 1.0 / (self.body_width if self.body_width is not None else mean_body_width())


# ----------------------------------------------------------------------------- input checks


def _array(x, shape, name) -> np.ndarray:
    x = np.asarray(x, dtype=np.float64)
    check_shape(x, shape, name)
    check_finite(x, name)
    return x


def _batch_shape(**shapes) -> tuple:
    """Broadcast the named batch shapes, or raise a ``ValueError`` naming them."""
    try:
        return np.broadcast_shapes(*shapes.values())
    except ValueError:
        listed = ", ".join(f"{name} {shape}" for name, shape in shapes.items())
        raise ValueError(f"expected batch (leading) dimensions that broadcast together, got {listed}") from None


def _broadcast(state, covariance, batch) -> tuple[np.ndarray, np.ndarray]:
    """``(state, covariance)`` as fresh arrays of shapes (*batch, 3) and (*batch, 3, 3)."""
    return np.broadcast_to(state, batch + (3,)).copy(), np.broadcast_to(covariance, batch + (3, 3)).copy()


def _nonnegative(x, name):
    if np.any(x < 0):
        raise ValueError(f"{name}: expected values >= 0, got a minimum of {x.min()}")


# ----------------------------------------------------------------------------- the phase LDS (Eqs. 15–17)


def transition_matrix(dt: float) -> np.ndarray:
    """``A`` of Eq. 16 (= ``F`` of Eq. 19), (3, 3): the phase advances by ``Δt·F``."""
    A = np.eye(3)
    A[PHASE, FREQUENCY] = dt
    return A


def control_matrix(phase_blend: float) -> np.ndarray:
    """``B`` of Eq. 16, (3, 3): ``diag(β, 1, 1)``."""
    B = np.eye(3)
    B[PHASE, PHASE] = phase_blend
    return B


def wrap_phase(phase) -> np.ndarray:
    """Phase (any shape, cycles) wrapped into [0, 1)."""
    phase = np.asarray(phase, dtype=np.float64)
    wrapped = phase - np.floor(phase)
    return np.where(wrapped >= 1.0, 0.0, wrapped)  # x − floor(x) rounds to 1 for tiny negative x


def phase_difference(a, b) -> np.ndarray:
    """``a − b`` on the circle (cycles), in [−0.5, 0.5)."""
    return wrap_phase(np.asarray(a, dtype=np.float64) - b + 0.5) - 0.5


def constrain(state, config: PhaseFilterConfig) -> np.ndarray:
    """Wrap the phase into [0, 1), clip the amplitude to [0, A_max] and the frequency to [0, F_m] (§5.2).

    Args:
        state: (..., 3) ``[S, A, F]``.
    """
    return _constrained(np.array(_array(state, (..., 3), "state")), config)


def _constrained(state: np.ndarray, config: PhaseFilterConfig) -> np.ndarray:
    """:func:`constrain` on a fresh float64 array it may change in place (no input checks)."""
    state[..., PHASE] = wrap_phase(state[..., PHASE])
    state[..., AMPLITUDE] = np.clip(state[..., AMPLITUDE], 0.0, config.amplitude_max)
    state[..., FREQUENCY] = np.clip(state[..., FREQUENCY], 0.0, config.frequency_max)
    return state


def lds_step(state, control, config: PhaseFilterConfig) -> np.ndarray:
    """One frame of the phase dynamics, ``X_{t+Δt} = A X_t + B U`` (Eq. 15), kept within bounds.

    Args:
        state: (..., 3) ``X_t = [S, A, F]`` (cycles, amplitude, Hz).
        control: (..., 3) ``U = [ΔS, ΔA, ΔF]`` (Eq. 17), broadcastable against ``state``.
    Returns:
        (..., 3) ``X_{t+Δt}``.
    """
    state = _array(state, (..., 3), "state")
    control = _array(control, (..., 3), "control")
    _batch_shape(state=state.shape[:-1], control=control.shape[:-1])
    A, B = transition_matrix(config.dt), control_matrix(config.phase_blend)
    return constrain(state @ A.T + control @ B.T, config)


def linear_control(state, goal, gain) -> np.ndarray:
    """Eq. 17's approximation of the network's update, ``U ≈ C (X_g − X_t)``, the phase error on the circle.

    Args:
        state: (..., 3) ``X_t``.
        goal: (..., 3) ``X_g``.
        gain: (..., 3, 3) the coefficient matrix ``C``.
    Returns:
        (..., 3) ``U``.
    """
    state = _array(state, (..., 3), "state")
    goal = _array(goal, (..., 3), "goal")
    gain = _array(gain, (..., 3, 3), "gain")
    _batch_shape(state=state.shape[:-1], goal=goal.shape[:-1], gain=gain.shape[:-2])
    error = goal - state
    error[..., PHASE] = phase_difference(goal[..., PHASE], state[..., PHASE])
    return np.einsum("...ij,...j->...i", gain, error)


def goal_phase_at(keyframe_state, frames_to_keyframe, config: PhaseFilterConfig) -> np.ndarray:
    """The goal phase state at frame ``t``, ``frames_to_keyframe = g − t`` frames before the keyframe ``g``: the
    keyframe's state carried along the free dynamics of Eqs. 15–16 (``U = 0``), ``X_g^p(t) = F^{t−g} X_g^p``
    with ``F = A`` of Eqs. 16 and 19, that is ``[S_g − (g − t) Δt F_g, A_g, F_g]``, the phase wrapped into [0, 1).

    The one goal-phase model of training (``features.clip_features``' goal phase inputs and ``P̂_g`` targets),
    the matched measurement (``runtime.rollout``) and the filter (whose Eq. 18 prediction ``F G^p`` of frame ``t``
    is this function at ``t + 1``): the goal phase advances by ``Δt F`` every frame and equals the keyframe's at
    ``g``. After the keyframe (``g − t < 0``) it goes on advancing.

    Args:
        keyframe_state: (..., 3) ``X_g^p = [S_g, A_g, F_g]`` of the keyframe (cycles, amplitude, Hz).
        frames_to_keyframe: ``g − t`` in frames (any sign, not necessarily whole), broadcastable against
            ``keyframe_state[..., 0]``.
        config: its ``dt`` is ``Δt``.
    Returns:
        (..., 3) float64 ``X_g^p(t)``, the batch shapes broadcast; amplitude and frequency the keyframe's.
    """
    keyframe_state = _array(keyframe_state, (..., 3), "keyframe_state")
    frames = _array(frames_to_keyframe, (...,), "frames_to_keyframe")
    batch = _batch_shape(keyframe_state=keyframe_state.shape[:-1], frames_to_keyframe=frames.shape)
    state = np.broadcast_to(keyframe_state, batch + (3,)).copy()
    state[..., PHASE] = wrap_phase(state[..., PHASE] - frames * config.dt * state[..., FREQUENCY])
    return state


# ----------------------------------------------------------------------------- the Kalman filter (Eqs. 18–22)


def process_noise(variance, config: PhaseFilterConfig) -> np.ndarray:
    """``Q`` of Eq. 19, (..., 3, 3): ``noise_scale · diag(σ̄)``.

    Args:
        variance: (..., 3) ``σ̄``, the dataset's variance of ``[S, A, F]`` (cycles², amplitude², Hz²), > 0.
    """
    variance = _array(variance, (..., 3), "variance")
    if np.any(variance <= 0):
        raise ValueError(f"variance: expected positive variances of [S, A, F], got a minimum of {variance.min()}")
    return _process_noise(variance, config)


def _process_noise(variance: np.ndarray, config: PhaseFilterConfig) -> np.ndarray:
    """:func:`process_noise` of a checked float64 ``σ̄``."""
    return config.noise_scale * variance[..., :, None] * np.eye(3)


def initial_goal_phase(batch_shape=()) -> tuple[np.ndarray, np.ndarray]:
    """Algorithm 1's initialisation ``G^p = 0``, ``P = 0``: (*batch_shape, 3) and (*batch_shape, 3, 3)."""
    batch_shape = tuple(batch_shape)
    return np.zeros(batch_shape + (3,)), np.zeros(batch_shape + (3, 3))


def _check_covariance(covariance, name) -> np.ndarray:
    covariance = _array(covariance, (..., 3, 3), name)
    _nonnegative(np.diagonal(covariance, axis1=-2, axis2=-1), f"{name} (its diagonal, variances)")
    return covariance


def predict(goal_phase, covariance, noise, config: PhaseFilterConfig) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 18: ``G^{p′} = F G^p``, ``P′ = F P Fᵀ + Q``.

    Args:
        goal_phase: (..., 3) ``G^p``.
        covariance: (..., 3, 3) ``P``.
        noise: (..., 3, 3) ``Q`` (:func:`process_noise`).
    Returns:
        ``(G^{p′}, P′)``, (..., 3) and (..., 3, 3), the batch shapes broadcast.
    """
    goal_phase = _array(goal_phase, (..., 3), "goal_phase")
    covariance = _check_covariance(covariance, "covariance")
    noise = _check_covariance(noise, "noise")
    batch = _batch_shape(goal_phase=goal_phase.shape[:-1], covariance=covariance.shape[:-2], noise=noise.shape[:-2])
    return _predicted(goal_phase, covariance, noise, config, batch)


def _predicted(goal_phase, covariance, noise, config, batch) -> tuple[np.ndarray, np.ndarray]:
    """:func:`predict` on checked float64 arrays, broadcast to ``batch``."""
    F = transition_matrix(config.dt)
    return _broadcast(_constrained(goal_phase @ F.T, config), F @ covariance @ F.T + noise, batch)


def update(goal_phase, covariance, measurement, noise, config: PhaseFilterConfig,
           active=None) -> tuple[np.ndarray, np.ndarray]:
    """One measurement of Eq. 20 (``H = I``): ``K = P (P + R)⁻¹``, ``G^p ← G^p + K (G_m − G^p)``,
    ``P ← (I − K) P``, the phase innovation taken on the circle.

    Args:
        goal_phase: (..., 3) ``G^p`` (after :func:`predict` or a previous update).
        covariance: (..., 3, 3) ``P``.
        measurement: (..., 3) ``G_m``, a goal phase state ``[S, A, F]``.
        noise: (..., 3, 3) ``R_m``.
        active: optional bool (...): where False the estimate is left as it is (no measurement).
    Returns:
        ``(G^p, P)`` updated, (..., 3) and (..., 3, 3), the batch shapes broadcast.
    """
    goal_phase = _array(goal_phase, (..., 3), "goal_phase")
    covariance = _check_covariance(covariance, "covariance")
    measurement = _array(measurement, (..., 3), "measurement")
    noise = _check_covariance(noise, "noise")
    batch = _batch_shape(goal_phase=goal_phase.shape[:-1], covariance=covariance.shape[:-2],
                         measurement=measurement.shape[:-1], noise=noise.shape[:-2],
                         **({} if active is None else {"active": np.shape(active)}))
    return _updated(goal_phase, covariance, measurement, noise, config, active, batch)


def _updated(goal_phase, covariance, measurement, noise, config, active, batch) -> tuple[np.ndarray, np.ndarray]:
    """:func:`update` on checked float64 arrays, broadcast to ``batch``."""
    innovation = measurement - goal_phase
    innovation[..., PHASE] = phase_difference(measurement[..., PHASE], goal_phase[..., PHASE])
    S = covariance + noise
    # K = P S⁻¹, solved as Sᵀ Kᵀ = Pᵀ.
    gain = np.swapaxes(np.linalg.solve(np.swapaxes(S, -1, -2), np.swapaxes(covariance, -1, -2)), -1, -2)
    updated = _constrained(goal_phase + (gain @ innovation[..., None])[..., 0], config)
    updated_covariance = covariance - gain @ covariance
    if active is not None:
        active = np.asarray(active, dtype=bool)
        updated = np.where(active[..., None], updated, goal_phase)
        updated_covariance = np.where(active[..., None, None], updated_covariance, covariance)
    return _broadcast(updated, updated_covariance, batch)


def _rotation_angle(rotations: np.ndarray) -> np.ndarray:
    """Angle ``θ`` of rotation matrices (..., 3, 3), radians in [0, π] (atan2: exact near 0 and π)."""
    axial = np.stack([rotations[..., 2, 1] - rotations[..., 1, 2],
                      rotations[..., 0, 2] - rotations[..., 2, 0],
                      rotations[..., 1, 0] - rotations[..., 0, 1]], axis=-1)
    trace = np.trace(rotations, axis1=-2, axis2=-1)
    return np.arctan2(0.5 * np.linalg.norm(axial, axis=-1), 0.5 * (trace - 1.0))


def _check_rotations(rotations, name):
    error = np.abs(np.swapaxes(rotations, -1, -2) @ rotations - np.eye(3)).max(initial=0.0)
    if error > 1e-6 or np.any(np.linalg.det(rotations) <= 0):
        raise ValueError(f"{name}: expected rotation matrices (orthonormal, det +1), "
                         f"got |RᵀR − I| up to {error:.2g}")


def bidirectional_deviation(ego_rotations, ego_positions, goal_rotations, goal_positions,
                            config: PhaseFilterConfig, check: bool = True) -> np.ndarray:
    """``c = Dev(T^inv, T^ego)`` of Eq. 22, the confidence scale of ``R_pred = c Q`` (Eq. 21):
    ``Σ_j α ‖log(r_jᵉᵍᵒᵀ r_jⁱⁿᵛ)‖_F + β ‖t_jᵉᵍᵒ − t_jⁱⁿᵛ‖``, where ``‖log r‖_F = √2 θ``
    for a rotation by ``θ``.

    Args:
        ego_rotations: (..., J, 3, 3) the egocentric key-joint predictions' rotations ``r^ego``.
        ego_positions: (..., J, 3) their positions ``t^ego``, metres.
        goal_rotations: (..., J, 3, 3) the goal-centric predictions mapped into the same frame by
            Eq. 14 (``G^{keyJ} T^{inv}``): ``r^inv``.
        goal_positions: (..., J, 3) their positions ``t^inv``, metres.
        check: False skips the input checks (shapes, finite values, orthonormal rotations) for float64 arrays
            that hold by construction, as in ``controller``'s inner loop.
    Returns:
        (...) ``c ≥ 0`` (dimensionless), summed over the ``J`` key joints.
    """
    if check:
        ego_rotations, ego_positions, goal_rotations, goal_positions = _checked_deviation_inputs(
            ego_rotations, ego_positions, goal_rotations, goal_positions)
    relative = np.swapaxes(ego_rotations, -1, -2) @ goal_rotations
    rotation_cost = np.sqrt(2.0) * _rotation_angle(relative)
    position_cost = np.linalg.norm(ego_positions - goal_positions, axis=-1)
    return (config.rotation_weight * rotation_cost + config.position_weight * position_cost).sum(axis=-1)


def _checked_deviation_inputs(ego_rotations, ego_positions, goal_rotations, goal_positions):
    """The four inputs of :func:`bidirectional_deviation` as float64 arrays, checked."""
    ego_rotations = _array(ego_rotations, (..., None, 3, 3), "ego_rotations")
    goal_rotations = _array(goal_rotations, (..., None, 3, 3), "goal_rotations")
    ego_positions = _array(ego_positions, (..., None, 3), "ego_positions")
    goal_positions = _array(goal_positions, (..., None, 3), "goal_positions")
    joints = ego_rotations.shape[-3]
    for name, x, axis in (("goal_rotations", goal_rotations, -3), ("ego_positions", ego_positions, -2),
                          ("goal_positions", goal_positions, -2)):
        if x.shape[axis] != joints:
            raise ValueError(f"{name}: expected {joints} key joints as ego_rotations, got {x.shape[axis]}")
    _batch_shape(ego_rotations=ego_rotations.shape[:-2], goal_rotations=goal_rotations.shape[:-2],
                 ego_positions=ego_positions.shape[:-1], goal_positions=goal_positions.shape[:-1])
    _check_rotations(ego_rotations, "ego_rotations")
    _check_rotations(goal_rotations, "goal_rotations")
    return ego_rotations, ego_positions, goal_rotations, goal_positions


def matched_measurement_active(root, root_goal, hand, hand_goal, config: PhaseFilterConfig,
                               check: bool = True) -> np.ndarray:
    """Algorithm 1's switch for the matched-motion measurement: ``Nearby(root) ∧ ¬Nearby(hand)``.

    Args:
        root, root_goal: (..., D) the root and its goal, metres (D = 2 on the ground, or 3).
        hand, hand_goal: (..., D) the working hand's wrist and its goal, metres.
        check: False skips the input checks for float64 arrays of matching shapes (``runtime.rollout``'s loop).
    Returns:
        bool (...): the root within ``nearby_radius`` of its goal and the hand not.
    """
    if check:
        root, root_goal = _array(root, (..., None), "root"), _array(root_goal, (..., None), "root_goal")
        hand, hand_goal = _array(hand, (..., None), "hand"), _array(hand_goal, (..., None), "hand_goal")
        for name, x, ref in (("root_goal", root_goal, root), ("hand_goal", hand_goal, hand)):
            if x.shape[-1] != ref.shape[-1]:
                raise ValueError(f"{name}: expected {ref.shape[-1]} coordinates as its point, got {x.shape[-1]}")
    root_near = np.linalg.norm(root - root_goal, axis=-1) < config.nearby_radius
    hand_near = np.linalg.norm(hand - hand_goal, axis=-1) < config.nearby_radius
    return root_near & ~hand_near


def filter_step(goal_phase, covariance, variance, predicted_goal, deviation, config: PhaseFilterConfig,
                matched_goal=None, use_matched=None, check: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """One pass of Algorithm 1's loop, after the network's inference.

    1. Predict (Eq. 18) with ``F`` and ``Q = 0.2 diag(σ̄)`` (Eq. 19).
    2. Update with the network's goal phase, ``R_pred = c Q`` (Eq. 21).
    3. Where ``use_matched``, update with the matched motion's goal phase, ``R_match = Q``.

    Args:
        goal_phase: (..., 3) ``G^p_t`` ``[S, A, F]``; covariance: (..., 3, 3) ``P_t``.
        variance: (..., 3) ``σ̄``, > 0.
        predicted_goal: (..., 3) ``G^p_pred``, the network's goal phase state.
        deviation: (...) ``c ≥ 0`` of Eq. 22 (:func:`bidirectional_deviation`).
        matched_goal: optional (..., 3) ``G^p_match``, the matched motion's phase at the goal.
        use_matched: bool (...) where to use it (:func:`matched_measurement_active`); ``None``:
            everywhere ``matched_goal`` is given.
        check: False skips the input checks (shapes, finite values, signs) for float64 arrays whose batch
            shapes broadcast, as in ``runtime.rollout``'s loop, which checks its inputs once.
    Returns:
        ``(G^p_{t+1}, P_{t+1})``, (..., 3) and (..., 3, 3).
    """
    if use_matched is not None and matched_goal is None:
        raise ValueError("use_matched: expected matched_goal (..., 3) with it, got matched_goal=None")
    # each input checked once; then Eqs. 18 and 20 on the checked arrays
    if check:
        goal_phase = _array(goal_phase, (..., 3), "goal_phase")
        covariance = _check_covariance(covariance, "covariance")
        predicted_goal = _array(predicted_goal, (..., 3), "predicted_goal")
        deviation = _array(deviation, (...,), "deviation")
        _nonnegative(deviation, "deviation")
        noise = process_noise(variance, config)
        if matched_goal is not None:
            matched_goal = _array(matched_goal, (..., 3), "matched_goal")
    else:
        noise = _process_noise(variance, config)
    shapes = dict(goal_phase=goal_phase.shape[:-1], covariance=covariance.shape[:-2], noise=noise.shape[:-2],
                  predicted_goal=predicted_goal.shape[:-1], deviation=deviation.shape)
    if matched_goal is not None:
        shapes["matched_goal"] = matched_goal.shape[:-1]
        if use_matched is not None:
            use_matched = np.asarray(use_matched, dtype=bool)
            shapes["use_matched"] = use_matched.shape
    batch = _batch_shape(**shapes)
    goal_phase, covariance = _predicted(goal_phase, covariance, noise, config, batch)
    goal_phase, covariance = _updated(goal_phase, covariance, predicted_goal, deviation[..., None, None] * noise,
                                      config, None, batch)
    if matched_goal is not None:
        goal_phase, covariance = _updated(goal_phase, covariance, matched_goal, noise, config, use_matched, batch)
    return goal_phase, covariance


def filter_sequence(variance, predicted_goals, deviations, config: PhaseFilterConfig, matched_goals=None,
                    use_matched=None, initial=None) -> tuple[np.ndarray, np.ndarray]:
    """Algorithm 1 over ``T`` frames, every character and channel at once.

    Args:
        variance: (..., 3) ``σ̄``.
        predicted_goals: (T, ..., 3) the network's goal phase per frame.
        deviations: (T, ...) ``c`` per frame, broadcastable against the batch.
        matched_goals: optional (T, ..., 3) the matched motion's goal phase per frame.
        use_matched: optional bool (T, ...) where to use it.
        initial: optional ``(G^p, P)``; default Algorithm 1's zeros.
    Returns:
        ``(G^p, P)`` after each frame, (T, ..., 3) and (T, ..., 3, 3).
    """
    predicted_goals = _array(predicted_goals, (..., 3), "predicted_goals")
    if predicted_goals.ndim < 2:
        raise ValueError(f"predicted_goals: expected shape (T, ..., 3), got {predicted_goals.shape}")
    frames = predicted_goals.shape[0]
    deviations = np.asarray(deviations, dtype=np.float64)
    for name, x in (("deviations", deviations), ("matched_goals", matched_goals), ("use_matched", use_matched)):
        if x is not None and (np.ndim(x) == 0 or np.shape(x)[0] != frames):
            raise ValueError(f"{name}: expected {frames} frames (as predicted_goals) first, got shape {np.shape(x)}")
    goal_phase, covariance = initial if initial is not None else initial_goal_phase(predicted_goals.shape[1:-1])
    states, covariances = [], []
    for t in range(frames):
        goal_phase, covariance = filter_step(
            goal_phase, covariance, variance, predicted_goals[t], deviations[t], config,
            matched_goal=None if matched_goals is None else matched_goals[t],
            use_matched=None if use_matched is None else use_matched[t])
        states.append(goal_phase)
        covariances.append(covariance)
    return np.stack(states), np.stack(covariances)


# ----------------------------------------------------------------------------- synthetic sequences (tests, benchmark)


class SyntheticGoalPhases(NamedTuple):
    """Goal-phase trajectories and their two measurements (:func:`synthetic_goal_phases`).

    Attributes:
        truth: (T, characters, channels, 3) ``[S, A, F]`` with the phase *unwrapped* (cycles).
        predicted: the network's measurements, the truth plus noise (same shape, unwrapped).
        matched: the matched motion's, the truth plus a bias and noise (same shape, unwrapped).
        deviations: (T, characters, 1) ``c``.
        use_matched: bool (T, characters, 1), the matched switch (on for a third of the frames).
        variance: (3,) ``σ̄`` of the wrapped truth.
    """

    truth: np.ndarray
    predicted: np.ndarray
    matched: np.ndarray
    deviations: np.ndarray
    use_matched: np.ndarray
    variance: np.ndarray


def synthetic_goal_phases(rng: np.random.Generator, frames: int, characters: int, channels: int,
                          config: PhaseFilterConfig = PhaseFilterConfig()) -> SyntheticGoalPhases:
    """Smooth toy goal phases (frequency 1.5–3 Hz, amplitude 0.3–0.6, both drifting) with noisy network
    measurements (noise 0.02 cycles, 0.03, 0.2 Hz), a biased matched measurement (half a noise unit off)
    and random deviations ``c`` in [0.05, 3] — the sequences the tests and ``scripts/bench_choice_kalman.py``
    run the filter and filterpy on. The phase starts within 0.3 cycles of 0, so that from Algorithm 1's
    zero start filterpy's (unwrapped) innovations stay on the same branch as ours."""
    t = np.arange(frames)[:, None, None] * config.dt
    shape = (characters, channels)
    frequency = rng.uniform(1.5, 3.0, shape) + 0.5 * np.sin(2 * np.pi * rng.uniform(0.1, 0.3, shape) * t)
    amplitude = rng.uniform(0.3, 0.6, shape) + 0.1 * np.cos(2 * np.pi * rng.uniform(0.1, 0.3, shape) * t)
    phase = rng.uniform(-0.3, 0.3, shape) + np.cumsum(frequency * config.dt, axis=0)
    truth = np.stack([phase, amplitude, frequency], axis=-1)
    noise_scale = np.array([0.02, 0.03, 0.2])
    predicted = truth + noise_scale * rng.standard_normal(truth.shape)
    matched = truth + noise_scale * (0.5 + rng.standard_normal(truth.shape))  # a biased prior
    deviations = rng.uniform(0.05, 3.0, (frames, characters, 1))
    start = rng.integers(0, frames // 2, characters)
    frame = np.arange(frames)[:, None]
    use_matched = ((frame >= start) & (frame < start + frames // 3))[..., None]
    wrapped = truth.copy()
    wrapped[..., PHASE] = wrap_phase(truth[..., PHASE])
    return SyntheticGoalPhases(truth, predicted, matched, deviations, use_matched, wrapped.reshape(-1, 3).var(axis=0))
