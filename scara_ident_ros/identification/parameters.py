"""The ``identifier`` node's parameters: names, defaults, units and rules, in one table.

:data:`IDENTIFIER_PARAMETERS` is the one source of their defaults: the node declares them
(``nodes.identifier.PARAMETERS`` is this table), ``config/identifier.yaml`` and
docs/parameters.md are checked and generated from it, and the typed settings everything
below the node takes are built from it
(:class:`~scara_ident_ros.identification.identifier_settings.IdentifierSettings`). No ROS
here.
"""
from __future__ import annotations

from scara_ident_ros.identification.contact_detector import (A_PRIORI, ARM_NMSE,
                                                             ENVELOPE_MARGIN,
                                                             FALSE_ALARMS_PER_HOUR, HELD_OUT,
                                                             MIN_SAMPLES, RECENT_S, SIGMA)
from scara_ident_ros.identification.differentiator import (CUTOFF_HZ, DIFFERENTIATOR_WINDOW,
                                                           DIFFERENTIATORS)
from scara_ident_ros.identification.error_window import MSE_WINDOW
from scara_ident_ros.identification.holdout import (VALIDATION_BLOCK, VALIDATION_BLOCK_S,
                                                    VALIDATION_FRACTION)
from scara_ident_ros.identification.learner_settings import NICE
from scara_ident_ros.identification.learner_methods import (GP_BUDGET, KERNEL_FEATURES,
                                                             LEARNER_BATCH, LEARNER_METHODS,
                                                             LEARNER_WARMUP)
from scara_ident_ros.identification.reservoir import RESERVOIR_SIZE
from scara_ident_ros.identification.reservoir_lm import LM_INTERVAL, LM_STEPS
from scara_ident_ros.identification.sample_check import DEFAULT_MAX_GAP_NS, LIMIT_MARGIN
from scara_ident_ros.identification.trainer import TRAINERS
from scara_ident_ros.nn.presets import HIDDEN_UNITS, METHODS
from scara_ident_ros.parameter_spec import ParamSpec

__all__ = ['ESTIMATE', 'HOLDOUT', 'IDENTIFIER_PARAMETERS', 'LIMITS', 'NETWORK',
           'ONLINE_METHODS', 'PHYSICAL_METHODS', 'START']

#: Models on the robot's URDF (they need it): its rigid-body model alone, learnt by RLS, or
#: with an FFS network of its residual.
PHYSICAL_METHODS = ('physical', 'hybrid')
#: Every model an identifier learns online (parameter ``method``): the networks, the
#: physical ones, the kernel learners.
ONLINE_METHODS = (*METHODS, *PHYSICAL_METHODS, *LEARNER_METHODS)

# Why a read-only parameter is fixed at start (shown by `ros2 param describe`)
NETWORK = "the network's shape and inputs (a saved model keeps them)"
HOLDOUT = 'which samples are held out must not change under the validation score'
ESTIMATE = "the q'' estimate keeps a history of samples"
LIMITS = "the network's input and output scaling"
START = 'used at start only'

IDENTIFIER_PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec('method', 'ffs', 'Model: the networks FFS (sigmoid, default: it identifies '
              "best, docs/results.md), FFMW (MSLOG, the paper's) or FFW (SLOG); physical "
              "(the URDF's rigid-body model with friction and rotor inertia, recursive least "
              'squares) or hybrid (physical plus an FFS network of its residual): these need '
              'urdf_file or robot_description; kernel (sparse-spectrum GP, random features, '
              'incremental), gp (exact GP with a budget) or linear (least squares on [q, '
              "q', q'', sin q, cos q, tanh(q'/0.05), 1], its batch solution after every "
              'batch: the best learner on TIAGo): need no URDF nor limits',
              choices=ONLINE_METHODS, fixed=NETWORK),
    ParamSpec('methods', [], 'Several networks from one subscription, each publishing under '
              '<method>/ in the node\'s namespace (the samples are checked and q\'\' '
              'estimated once); empty: method alone, publishing in the node\'s namespace',
              items=str, choices=ONLINE_METHODS, fixed=NETWORK),
    ParamSpec('joint_names', [], 'Joints to identify, in this order; empty: the joints of '
              'the first valid message (or of the warm-start model)', items=str, fixed=NETWORK),
    ParamSpec('min_joints', 1, 'Without joint_names: take the joints of the first valid '
              'message naming at least this many (a partial message does not fix the set)',
              min=1, max=1000, fixed=NETWORK),
    ParamSpec('hidden_units', HIDDEN_UNITS, 'Hidden units of the network', min=1, max=10_000,
              fixed=NETWORK),
    ParamSpec('seed', 0, 'Seed of the initial weights, the reservoir and the validation '
              'blocks', min=0, fixed='the weights are drawn once (~/reset draws them again)'),
    ParamSpec('learning_rate', 0.0, "Online learning rate of trainer bp; 0: the method's "
              'default', min=0.0, max=10.0, read_only=False),
    ParamSpec('momentum', -1.0, "Online momentum in [0, 1) of trainer bp; negative: the "
              "method's default", min=-1.0, max=0.999, read_only=False),
    ParamSpec('k', 2.5, 'MSLOG gain K (ffmw only)', fixed=NETWORK),
    ParamSpec('a', 5.0, 'MSLOG divisor a in z = (x·v − b)/a (ffmw only)', fixed=NETWORK),
    ParamSpec('b', 5.0, 'MSLOG offset b (ffmw only)', fixed=NETWORK),
    ParamSpec('learn', True, 'Learn online; false: predict only, with the model frozen as '
              'it is (samples without effort are then predicted too; an update a learner '
              'process finishes meanwhile is taken when learning resumes)', read_only=False),
    ParamSpec('trainer', 'lm', 'Online training: lm (Levenberg-Marquardt steps on a reservoir '
              'of the whole stream, generalizes) or bp (the paper: one back-propagation step '
              'per sample, tracks)', choices=TRAINERS, fixed='the trainer keeps its state'),
    ParamSpec('reservoir_size', RESERVOIR_SIZE,
              'Samples of the stream kept for the lm trainer (and the reservoir a fresh '
              'kernel or gp learner is refitted on)', min=10, max=1_000_000,
              fixed='the reservoir is allocated once'),
    ParamSpec('lm_steps', LM_STEPS, 'Levenberg-Marquardt steps of the lm trainer per update',
              min=1, max=100, read_only=False),
    ParamSpec('lm_interval', LM_INTERVAL,
              'Samples between two updates of the lm trainer (beside '
              'the stream: the least new samples between two)', min=1,
              max=1_000_000, read_only=False),
    ParamSpec('lm_background', True, 'lm trainer (and methods kernel, gp): learn in a '
              'process beside the stream, at '
              'lower CPU priority, so that no sample waits for a step (when the CPU is short, '
              'learning slows down and the updates/s say so); false: steps in the message '
              'path every lm_interval samples (reproducible, for experiments)',
              fixed='the trainer is built once'),
    ParamSpec('lm_nice', NICE, 'lm trainer beside the stream: niceness its learner process adds '
              "to the node's: above 0 the stream's processes go first when the CPU is short "
              '(learning slows down, the stream does not); 0 gives learning an equal share',
              min=0, max=19, fixed='the learner process is started once'),
    ParamSpec('lm_float64', False, 'lm trainer: assemble its normal equations in float64 '
              '(more CPU)', fixed='the trainer is built once'),
    ParamSpec('lm_slow_share', 0.0, 'lm trainer: share of reservoir_size kept for samples '
              'where some joint moves slower than 1 % of its velocity limit (the friction '
              'step at zero speed); 0: one uniform reservoir', min=0.0, max=0.5,
              fixed='the reservoir is allocated once'),
    ParamSpec('lm_friction_steps', True, 'lm trainer: the first hidden units start as steps '
              "of each joint's speed at 0, the shape of Coulomb friction (half-widths 6.4, "
              '1.6, 0.4, 0.1 and 0.025 % of the velocity limit), the others random; false: all '
              'random (a Coulomb step is then learnt slowly, docs/results.md)', fixed=NETWORK),
    ParamSpec('kernel_features', KERNEL_FEATURES, 'Random features D of method kernel (its '
              'cost per learnt sample grows as D²)', min=2, max=20_000, fixed=NETWORK),
    ParamSpec('gp_budget', GP_BUDGET, 'Most points of method gp (its factor takes '
              f'gp_budget² doubles: {GP_BUDGET} = {8 * GP_BUDGET**2 // 10**6} MB)', min=500,
              max=100_000, fixed=NETWORK),
    ParamSpec('learner_batch', LEARNER_BATCH, 'Methods kernel and gp: samples per '
              'partial_fit call of the learner (beside the stream with lm_background: at '
              'least this many); 1: each sample learnt as it comes', min=1, max=100_000,
              fixed='the learner is built once'),
    ParamSpec('learner_warmup', LEARNER_WARMUP, 'Methods kernel and gp: samples gathered '
              'before the learner\'s first partial_fit (its input and effort standardisation '
              'and kernel come from them; predicted by their running mean meanwhile): they '
              'should span the motion to come', min=2, max=1_000_000,
              fixed='the learner is built once'),
    ParamSpec('validation_fraction', VALIDATION_FRACTION,
              'Fraction of the samples (in blocks) never learnt, '
              'whose error is the validation NMSE; 0: none', min=0.0, max=0.9,
              fixed=HOLDOUT),
    ParamSpec('validation_block', VALIDATION_BLOCK,
              f'Samples per held-out block; 0: {VALIDATION_BLOCK_S:g} s of the stream\'s '
              f'stamps whatever its rate ({VALIDATION_BLOCK_S * 1000:g} samples at 1 kHz, '
              f'{VALIDATION_BLOCK_S * 100:g} at 100 Hz)', min=0, max=1_000_000,
              fixed=HOLDOUT),
    ParamSpec('model_path', '', 'Warm-start from this saved model (.npz; with methods, '
              '{method} in the path stands for each method); empty: fresh',
              fixed='read once, at start'),
    ParamSpec('save_path', '', 'Save the model here periodically and on shutdown (atomically; '
              'with methods, {method} in the path stands for each method); '
              'a model already there is continued from, not replaced (unless model_path is '
              'given); empty: never', fixed='a model there is continued from at start'),
    ParamSpec('checkpoint_period', 60.0, 'Seconds between checkpoints to save_path; 0: only '
              'on shutdown (and ~/save_model)', 's', min=0.0, read_only=False),
    ParamSpec('mse_window', MSE_WINDOW, 'Samples in the windowed MSE (a change starts the window '
              'anew)', min=100, read_only=False),
    ParamSpec('mse_rate_hz', 10.0, 'Rate of identification_mse', 'Hz', min=0.01, max=1000.0,
              read_only=False),
    ParamSpec('differentiator', 'centred', 'How acceleration is estimated from velocity: '
              'centred (zero-phase, window // 2 samples late) or a causal filter',
              choices=DIFFERENTIATORS, fixed=ESTIMATE),
    ParamSpec('derive_velocity', 'auto', "q' of a stream that carries none (positions and "
              "efforts only): auto = from the positions, in the q'' estimate's window; never "
              '= such samples are skipped (no_velocity)', choices=('auto', 'never'),
              fixed=ESTIMATE),
    ParamSpec('cutoff_hz', CUTOFF_HZ, 'Cut-off of the lowpass differentiator', 'Hz', min=0.1,
              fixed=ESTIMATE),
    ParamSpec('window', DIFFERENTIATOR_WINDOW,
              'Samples of the centred (odd) and polynomial differentiators', min=3, max=101,
              fixed=ESTIMATE),
    ParamSpec('limit_margin', LIMIT_MARGIN,
              'Refuse samples (out_of_limits) whose position leaves the '
              'joint range by more than this fraction of the range, or whose velocity or '
              'effort exceeds its limit by more than this fraction; negative: no check',
              min=-1.0, max=100.0, fixed=LIMITS),
    ParamSpec('max_gap', DEFAULT_MAX_GAP_NS / 1e9,
              'A larger gap between stamps, if also longer than 5 observed '
              'sample periods (100 Hz: 50 ms), restarts the differentiator', 's', min=0.0,
              fixed=ESTIMATE),
    ParamSpec('robot_config', '', "Robot YAML whose joint limits scale the network's inputs "
              'and outputs; empty: the installed config/scara.yaml', fixed=LIMITS),
    ParamSpec('urdf_file', '', 'URDF whose joint <limit>s (position, velocity, effort), '
              'matched by joint name, replace those of robot_config; acceleration limits '
              '(URDF has none) from acceleration_max with joint_names, else a robot_config '
              "naming the joints, else 2 x the largest q'' of the stream's first second (a "
              'continuous joint: all its limits so); empty: none', fixed=LIMITS),
    ParamSpec('robot_description', '', 'The URDF as a string, as robot_state_publisher has '
              'it: used like urdf_file', fixed=LIMITS),
    ParamSpec('position_min', [], 'Per-joint position lower limits (rad or m); with the four '
              'below, replaces robot_config for another robot', items=float, fixed=LIMITS),
    ParamSpec('position_max', [], 'Per-joint position upper limits (rad or m)', items=float,
              fixed=LIMITS),
    ParamSpec('velocity_max', [], 'Per-joint |velocity| limits (rad/s or m/s)', items=float,
              fixed=LIMITS),
    ParamSpec('acceleration_max', [], 'Per-joint |acceleration| limits (rad/s² or m/s²)',
              items=float, fixed=LIMITS),
    ParamSpec('effort_max', [], 'Per-joint |effort| limits (N·m or N)', items=float,
              fixed=LIMITS),
    ParamSpec('wait_for_subscribers', 0, 'Subscribe joint_states only once identified_torque '
              'and identification_mse (of each method) each have this many subscribers (e.g. '
              'a recorder), so that no prediction goes unheard; 0: at once', min=0,
              fixed=START),
    ParamSpec('wait_timeout', 30.0, 'Longest wait for those subscribers', 's', min=0.0,
              fixed=START),
    ParamSpec('stats_file', '', 'Write the final counters and errors here as JSON on '
              'shutdown (with methods, {method} in the path stands for each method); empty: '
              'never', fixed='checked writable at start'),
    ParamSpec('contact_false_alarms_per_hour', FALSE_ALARMS_PER_HOUR,
              'Contact detection is armed only when '
              'the false-alarm rate on free motion, estimated from the tail of the model\'s '
              'residuals (contact_calibration; their size counted), is at most this; the '
              'thresholds are set to meet it', min=1e-6, max=1e6, read_only=False),
    ParamSpec('contact_calibration', A_PRIORI, 'The residuals the contact thresholds come '
              'from: a-priori = every sample\'s, predicted before it was learnt, over the last '
              'contact_calibration_window (what the check meets: motion not learnt yet); '
              'held-out = the current model\'s on the held-out segments (motion between learnt '
              'motion: its error on new motion is larger)', choices=(A_PRIORI, HELD_OUT),
              read_only=False),
    ParamSpec('contact_calibration_window', RECENT_S, 'Stream time of a-priori residuals the '
              'contact thresholds are calibrated on (at most this many thousand samples are '
              'kept)', 's', min=2.0, max=600.0, read_only=False),
    ParamSpec('contact_sigma', SIGMA, 'Lowest contact threshold of each joint, in robust '
              "standard deviations (1.4826 x MAD) of the model's residuals the thresholds come "
              'from (the false-alarm bound usually sets a higher one)',
              min=0.1, max=1000.0, read_only=False),
    ParamSpec('contact_arm_nmse', ARM_NMSE, 'Contact detection is armed only while the '
              'validation NMSE (mean over the joints) is below this', min=1e-12, max=10.0,
              read_only=False),
    ParamSpec('contact_envelope_margin', ENVELOPE_MARGIN, 'Samples whose q or q\' (and q\'\' '
              'with contact_envelope_acceleration) leave the range of the samples the '
              'thresholds come from (a-priori: with the held-out segments\'), widened by this '
              'fraction of it, are not checked for contact (diagnostics count them)', min=0.0,
              max=10.0, read_only=False),
    ParamSpec('contact_envelope_acceleration', False, "Bound q'' too by the calibrated "
              "envelope; false: q and q' only (a contact is itself an acceleration the free "
              'motion does not have: bounding q\'\' holds the samples a collision makes)',
              read_only=False),
    ParamSpec('contact_calibration_period', 10.0, 'Seconds between the starts of two '
              'calibrations of the contact thresholds on the held-out segments (each predicts '
              'them all, in steps of 2000 samples every 50 ms)', 's', min=0.1, max=3600.0,
              read_only=False),
    ParamSpec('contact_min_samples', MIN_SAMPLES,
              'Consecutive samples over the threshold before a '
              'joint is reported on contact', min=1, max=1000, read_only=False),
    ParamSpec('external_torque', True, 'Publish external_torque (measured - predicted) for '
              'every prediction; false: contact detection only (one message less per sample '
              'and method)', read_only=False),
)
