"""CHOICE §5: the goal-driven deep-phase controller (§5.1, Eqs. 13–14, 22, Algorithm 1, Fig. 4; Table 4's variants).

Modules: ``phase`` (the DeepPhase periodic autoencoder, §5, §7), ``kalman`` (the phase dynamical system and
the goal-phase Kalman filter, Eqs. 15–22, Algorithm 1), ``features`` (key joints, goal phase, the input and
output layouts), ``network`` (configuration, training data, Fig. 4's network and its training), ``runtime``
(the step and the rollout with Table 4's goal-phase sources) and ``measures`` (Table 4's measures, Table 2's
labels, §7, §8.3.1; Table 4's runs, whose goals come from §6.1's matching, are ``pick_and_place.table4``).

The algorithm box, as this package runs it (``B`` characters, ``C`` PAE channels, ``K = 4`` key joints
root / hip / left wrist / right wrist, ``w = 13`` samples over 2 s):

1. **Data** (:func:`network.controller_data`): toy reach-and-grasp clips (approach walk, reach, grasp); door and
   drawer clips (walk, reach the handle, pull) too when ``ControllerConfig.kinds`` names them. Keyframes
   are the grasp (``meta["anchor_frame"]``) and the clip's last frame; ``g(t)`` is the next keyframe at
   or after ``t``. The PAE (``phase``) gives every frame's ``(S, F, A)``.
2. **Inputs** ``X_t`` (all in the root frame of ``t``): the pose (root-relative joint positions and
   velocities), the 2D root trajectory (13 samples over ``[t − 1 s, t + 1 s]``: position and forward
   direction), the goals ``G_t^keyJ`` (the four key joints' positions and 6D rotations at 13 samples
   centred on ``g``), the current phase ``A·(sin 2πS, cos 2πS), F`` and the goal phase features of
   Eq. 13, ``P̃_g = (A_g·sin 2πS_g + ε, A_g·cos 2πS_g + ε, F_g + ε)``, ``ε ~ N(0, 0.1)`` in training, of the goal
   phase state of frame ``t``: the keyframe's ``[S, A, F]`` carried to ``t`` by Eqs. 15–16,
   ``[S_g − (g − t) Δt F_g, A_g, F_g]`` (``kalman.goal_phase_at``, the one goal-phase model of training, the
   matched measurement and the filter), and
   the hip's and wrists' 6D trajectories over the next second (7 samples ``t + 5k``; §5.1: "in addition to
   the 2D root trajectories on the ground, the 6D transformations of the hip and left/right wrists are also
   given"): the recorded ones in training, noised by ``key_noise``; at run time the previous step's blend.
3. **Network** (Fig. 4): a gating network that compares the key joints' transformations and the phase, now
   and at the goal (the hip's and wrists' position and 6D rotation at ``t``, the four key joints' at the goal
   keyframe, the current and goal ``A·sin, A·cos``), blends the experts of an MoE main network
   (``nn.moe.MoEMLP``).
4. **Outputs** ``Y_{t+1}``: the next pose (in the next root frame) — the 22 joints' local rotations in 6D
   (``features.local_rotation_features``), with the joint positions and velocities as an auxiliary output —
   with the root's update, the next
   phase, the egocentric key-joint trajectory ``T^ego_{t+1}`` (1 s ahead, in the root frame of ``t``),
   the goal-centric one ``T^inv_{t+1}`` (each key joint in its own goal frame ``G``), and the goal
   estimate ``Ĝ`` (13-sample window at ``g``) with its phase ``P̂_g`` (the goal phase state of ``t + 1``).
5. **Run time** (:func:`runtime.controller_step`): the body is posed by forward kinematics from the predicted
   rotations, blended half-way from the previous frame's, with each character's bone offsets
   (``features.pose_from_rotations``: every bone keeps its length). ``G T^inv`` (Eq. 14) is blended with ``T^ego``
   with a weight that grows as the working wrist nears its goal; the blended trajectories are the next step's inputs
   (the root's as its future root trajectory, the hip's and wrists' as theirs: Fig. 4, "our bi-directional control
   blends the key-joint transformation prediction", fed back as NSM feeds back its control signals).
   ``c = Dev(G T^inv, T^ego)`` (Eq. 22) is returned for the Kalman filter. The phase moves by Eqs. 15–16
   (:func:`runtime.phase_update`): ``X_{t+Δt} = A X_t + B U``, the phase advanced by its frequency and moved
   ``β = 0.5`` of the way to the network's, the amplitude and frequency the network's, all within bounds.
6. **Goal phase sources** (:func:`runtime.rollout`, Table 4): ``"none"`` (zeros), ``"matched"`` (the matched
   clip's phase at its keyframe carried to each frame by ``kalman.goal_phase_at``, the keyframe due
   ``KeyJointGoal.due`` frames after the start), ``"predicted"`` (the network's own ``P̂_g`` fed back),
   ``"kalman"`` (``kalman.filter_step`` on the network's ``P̂_g`` with ``R_pred = c Q`` and the matched phase
   with ``R = Q`` where ``matched_measurement_active``; Algorithm 1, whose prediction ``F G^p`` advances the goal
   phase as the goal-phase model does). Each is bounded alike: the amplitude in
   ``[0, A_max]``, ``A_max`` the largest amplitude of the training frames (``runtime.phase_filter_config``).

Choices the paper does not state, ours:

- One network serves all four variants: in training the goal phase features are zeroed with
  probability ``phase_dropout``, so that ``"none"`` (zeros) is a state the network has seen.
- Key-joint transforms: the root is the pelvis projected to the ground with the hips' heading
  (``world.features.root_frame``); the hip is the pelvis joint; rotations are global, as 6D.
- The goal window is the 13 frames ``g + 5k`` (k = −6..6, clamped to the clip), one ``g`` for the whole
  window (the paper's per-sample ``g(t')`` differs only across a keyframe).
- The future windows (ego, goal-centric, blended root) are the 7 samples ``t + 1 + 5k`` (k = 0..6).
- The blend weight is ``λ = clip(1 − d / blend_radius, 0, 1)``, ``d`` the working wrist's distance to
  its goal; positions and 6D rotations are blended linearly and the rotations re-orthonormalised.
- ``c`` of Eq. 22 is the mean over the 7 future samples of the sum over the 4 key joints.
- ``σ̄`` of Eq. 19 is the variance of ``[S, A, F]`` per channel over the training frames (``S`` as the
  wrapped number in [0, 1), not a circular variance).
- The filter starts from the matched goal phase of the first frame with ``P = 0`` (Algorithm 1 initialises the
  goal on the click; the paper's ``G^p = 0`` would feed a zero goal phase at first). ``"predicted"`` starts
  from it too.
- The goal phase of frame ``t`` is the keyframe's carried back along the free dynamics (Eqs. 15–16), so that it
  advances by ``Δt F`` a frame, as the filter's ``F`` predicts it, and meets the keyframe's phase at ``g``
  (``kalman``'s notes quote §5.2 for it). The time ``g − t`` at run time is ``KeyJointGoal.due`` less the steps
  taken: a demo's contact frame, or in Table 4 the matched clip's own grasp frame.
- Training is teacher-forced, then, for its last ``unroll_steps``, unrolled over ``unroll`` frames on the
  network's own pose, phase and future root trajectory (:func:`network.train_controller`); inputs and outputs
  are standardised with the training data's mean and std; the loss is the mean squared error in those units.
- The network predicts the next phase itself (as DeepPhase's controllers do); Eq. 17's control ``U`` is the update
  that takes ``A X_t`` to that prediction (the phase's on the circle), so that ``β = 1`` would follow the network.
  Training fits the network's prediction; Eqs. 15–16 act at run time only.
- At run time each joint moves half-way from its previous position carried by the predicted velocity to the
  predicted position (``features.POSE_BLEND``, :func:`features.blended_pose`), as Starke et al.'s released
  controllers do.
- A rollout starts with the future root trajectory on the straight line to the goal's root at 1 m/s
  (:func:`runtime.toward_goal`; a standing start is a fixed point the toy controller may not leave).

Measured at toy (one CPU thread): 48 clips, about 8 400 frames, 2400 steps (the last 400 unrolled over 6 frames)
in 51 / 54 / 52 s with seeds 0 / 1 / 2. The distances below were measured with the keyframe's goal phase held
constant in training and matching, not yet with the goal-phase model of step 2. On 12 unseen reaches the working wrist comes within a median 0.13 / 0.22 /
0.31 m of its grasp with the Kalman goal phase, 0.08 / 0.17 / 0.20 m without a goal phase (Table 4's runs when
their goals were the test clips' own keyframes; with goals matched in the library and approaches planned by §4,
``pick_and_place.table4``, and the phase moved by Eqs. 15–16, 0.13 / 0.24 / 0.33 m with the Kalman goal phase and
0.12 / 0.22 / 0.29 m without); 3000 steps (600 unrolled) took about 70 s for Kalman medians of 0.13 / 0.31 / 0.38 m.
Before the hip's and wrists' trajectories were inputs, those medians were 0.37 / 0.40 / 0.14 m, and with seed 2 some
characters blew up (unsmoothness 3 346 cm/s², against 156 now). Trained on 16 clips of each of
``features.CLIP_KINDS`` instead (about as many frames, 2400 steps), the door wrist of
``pick_and_place.demo.controller_at_cabinet`` came within 0.31 / 0.22 / 0.28 m of the demo's handle from its
standing start, against 0.63 / 0.43 / 0.43 m: nearer, still 20–30 cm short, while Table 4's Kalman row slid 246 / 389 / 193 cm/s² against 158 / 98 / 194 and, with seed 1, moved less
smoothly than the recorded clips (381 against 299 cm/s²). So the toy preset keeps reach-and-grasp clips only.

Scaling (paper → toy): 8 PAE channels → 4 (``phase``); gating 3 × 128 → 2 × 64 hidden + output, main
network 3 × 512 → 3 × 128; experts (not stated in CHOICE; DeepPhase 8) → 4; 70 % of 150 sequences for
150 epochs (8 h) → ``clips`` toy clips for ``steps`` batches; 60 fps → 30 fps; the toy body's 22 joints (their
local rotations in 6D, with positions and velocities as an auxiliary output: step 4 above) stand for the paper's
pose.
"""
from . import features, kalman, measures, network, phase, runtime

__all__ = ["phase", "kalman", "features", "network", "runtime", "measures"]
