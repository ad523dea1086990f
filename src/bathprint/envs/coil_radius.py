"""``bathprint/CoilRadius-v0``: print coils whose radius (and pitch) follow a target schedule."""

from __future__ import annotations

from bathprint.envs.shape_env import ShapeEnv
from bathprint.envs.v0 import BathprintEnvV0
from bathprint.envs.v1 import BathprintEnvV1


class CoilRadiusEnv(BathprintEnvV0):
    """
    Deprecated: ``bathprint/CoilRadius-v1`` is the newest version (making this one warns);
    registered so that results made with it reproduce.

    ## Description

    A soft alginate filament (22G needle, d = 0.41 mm) is extruded downwards into a viscous
    CaCl2 bath, gels (its modulus grows from 300 Pa to 30 kPa at 0.5 1/s, curvature freezes
    in as it sets) and, compressed by drag, buckles and coils. The coil radius follows the
    extrusion speed, R ~ 0.4 (B / (mu v))^(1/3) (B = E pi r^4 / 4, v = (Q_o + Q_i) / (pi d^2/4)):
    at 0.5 ml/min R ~ 3.7 mm, at 2 ml/min ~ 2.1 mm. The agent sets the flow rates so that the
    coils printed along the filament follow a target schedule of radius (and pitch) given as a
    function of printed arclength (1-3 sections of radius 2.25-4.5 mm, pitch 0.5 or 1.5 mm,
    4 mm ramps between them). Coils form about one buckling length below the needle, so the
    flow must change *before* the target does: the observation shows the target ahead.
    Pitches above the natural one (~0.5 mm) need the needle (``needle_velocity=True``).

    Scene: ``gelation_coiling_22G`` with the ``inclusions`` effect (silicone oil), needle tip at
    z = -10 mm pointing down; spec ``envs/coil_radius.toml``.

    ## Action Space

    ``Box(-1, 1, (2,), float32)`` (``(5,)`` with ``needle_velocity=True``, ``(4,)`` with
    ``"xy"``), mapped affinely and clipped; a NaN raises ``ValueError``:

    | index | control | physical range |
    |-------|---------|----------------|
    | 0 | Q_o, alginate flow rate | 0.25 - 2.0 ml/min |
    | 1 | Q_i, co-extruded oil flow rate | 0 - 0.2 ml/min (inner fraction <= 0.9) |
    | 2-4 | needle velocity x, y, z (optional) | +-10 mm/s each |

    The needle tip is kept in the box [-15, 15] x [-15, 15] x [-30, -3] mm.

    A step holds these for the time that prints 1 mm of filament (4-60 ms).

    ## Observation Space

    ``Box(-10, 10, (94,), float32)``, the same layout in every bathprint environment
    (``bathprint.envs.observation.OBS_LAYOUT``); lengths / 10 mm, speeds / 100 mm/s,
    curvatures x 3 mm, densities as (rho - 1054) / 50 kg/m^3; clipped to +-10, never NaN:

    | slice | content |
    |-------|---------|
    | 0-35 | filament positions relative to the tip, 1, 2, 3, 4, 6, 8, 10, 13, 16, 20, 25 |
    |      | and 30 mm of material behind the needle tip (x, y, z each) |
    | 36-47 | velocities 2, 6, 13, 25 mm behind the tip |
    | 48-53 | curvature of the filament 4, 8, 13, 18, 25, 30 mm behind the tip |
    | 54-59 | density of the material 0.5, 2, 5, 10, 20, 30 mm behind the tip |
    | 60-83 | target curvature, torsion and density aim at printed arclength |
    |       | s - 30, -20, -10, +0, +5, +10, +15, +20 mm (s: length printed so far) |
    | 84-89 | current Q_o and Q_i (action units), inclusion offset (action units), |
    |       | needle displacement from its start (x, y, z) |
    | 90-93 | printed / episode length, scored fraction, metric / missing_error, |
    |       | mean error of the last 10 scored samples / missing_error |

    ## Rewards

    The decrease of the shape metric M over the step (``bathprint.envs.metric``): windowed
    (20 mm) Kabsch RMS distance between printed and target centrelines, arclength-matched,
    over 3 mm, plus 0.5 x the curvature difference x 3 mm, per sample, RMS over the target;
    samples not yet 20 mm from the needle count as ``missing_error`` = 2. The return of an
    episode is M_0 - M_final = 2 - M_final (telescoping).

    ## Starting State

    A filament already coiling: 30 mm printed at Q_o = 0.5 ml/min from a 2-node stub, one
    of 4 needle-imperfection seeds (drawn from ``np_random``; computed once per process and
    cached). The target is drawn from ``np_random`` (training set) or taken from the fixed
    evaluation set, or a file.

    ## Episode End

    Terminated when the target's length plus the settling length (60 + 20 mm: 80 steps) has
    been printed. Truncated if the simulation diverges (``info["sim_error"]`` says why; the
    observation is the last finite one, the reward 0).

    ## Arguments

    ``gymnasium.make("bathprint/CoilRadius-v0", render_mode=None, accuracy="balanced",
    needle_velocity=False, target_set="train", target_index=None, target_file=None,
    scene_overrides=None, spec_overrides=None, spec_file=None)``

    - ``accuracy``: ``"draft" | "balanced" | "fine"`` (``bathprint.envs.accuracy``).
    - ``needle_velocity``: ``True`` / ``"xyz"`` or ``"xy"`` adds needle velocity components.
    - ``target_set``: ``"train"`` (seeded draws, never an evaluation target) or ``"eval"``
      (the fixed held-out set: ``target_index`` or ``reset(options={"target_index": k})``,
      else cycling 0, 1, ... from the last seeded reset).
    - ``target_file``: a CSV/NPY polyline (``bathprint.envs.targets.load_target_file``).
    - ``scene_overrides``: dotted scene keys applied last; ``spec_overrides``: a nested
      dict merged into the spec (e.g. ``{"target": {"length_mm": 40}}``).
    - ``render_mode``: ``"rgb_array"`` (filament and target overlaid, and the curvature
      along arclength) or ``"human"``.
    """

    env_id = "bathprint/CoilRadius-v0"


class CoilRadiusEnvV1(BathprintEnvV1):
    """
    ## Description

    ``CoilRadius-v0``'s task made well-posed: print coils whose radius follows a target
    schedule along the printed length, with the alginate flow rate Q_o (R falls from ~5.6 mm
    at 0.25 ml/min to ~2.3 mm at 2 ml/min, draft preset). Every target is a filament this
    environment printed from a random schedule of 1-3 flow sections (4 mm ramps) and one of
    its warm-up states, so that replaying the schedule reaches it exactly at the print
    preset (``draft``). Full description, spaces, reward, success and reference scores:
    ``docs/envs/CoilRadius-v1.md``; spec ``envs/coil_radius_v1.toml``.

    ## Action Space

    ``Box(-1, 1, (1,), float32)``: log Q_o, -1 -> 0.25 ml/min, +1 -> 2.0 ml/min (equal
    steps, equal ratios of flow). ``needle_velocity=True`` / ``"xy"`` adds needle velocity
    components (+-10 mm/s; the targets do not need them).

    ## Observation Space

    ``Box(-10, 10, (75,), float32)`` (``obs_layout``): filament near the tip (36), velocities
    (12), printed curvature (6), target curvature and torsion from 30 mm behind to 20 mm
    ahead (16), the current action (1), progress (4: printed fraction, scored fraction, RMS
    error of the scored samples and of the last 10, / missing_error). With
    ``goal_conditioned=True``: a Dict of observation (57), achieved_goal and desired_goal
    (365: 121 sample positions, counts).

    ## Rewards

    The decrease of sum_j e_j^2 / N over the scored samples (e_j: the metric's per-sample
    error, ``bathprint.envs.metric``); the return is -M_final^2. ``info["metric"]`` is M.

    ## Episode End

    Terminated after 2 + 60 + 20 mm (82 steps); truncated if the simulation diverges (the
    unscored samples then count as missing in the last reward). ``info["is_success"]``: the
    finished print has M <= 0.1.

    ## Arguments

    ``render_mode``, ``accuracy``, ``needle_velocity`` (None: the spec's), ``target_set``
    (``"train" | "validation" | "test"``), ``target_index``, ``target_file``,
    ``goal_conditioned``, ``scene_overrides``, ``spec_overrides``, ``spec_file``.
    """

    env_id = "bathprint/CoilRadius-v1"


class CoilRadiusEnvV2(ShapeEnv):
    """
    ## Description

    Coil a shape of the free family (``bathprint.envs.shapes``): barrels, alternating and
    flat-spiral coils for training and the named validation and test shapes, cones held out
    (``ood_test``), with the alginate flow alone (coil radius 2.3-5.6 mm; the paper's
    R ~ 0.4 (B / (mu v))^(1/3)). The scene, actions and episode of ``CoilRadius-v1``. Scored
    by the whole-shape error in mm after the best proper rotation and translation
    (``docs/shapes.md``); success: RMS <= 0.8 mm and max <= 2 mm. The pitch is not an
    action: a coil's pitch is what the hanging stack makes of it.
    ``docs/envs/CoilRadius-v2.md``; spec ``envs/coil_radius_v2.toml``.

    ## Action Space

    ``Box(-1, 1, (1,), float32)``: log Q_o (0.25-2.0 ml/min).

    ## Observation Space

    ``Box(-10, 10, (72,), float32)``: the filament near the needle, the target's curvature
    and torsion from 30 mm behind to 20 mm ahead, the control, progress (printed fraction,
    scored fraction, scored-prefix RMS error / 4 mm) (``obs_layout``).

    ## Rewards

    Potential-based on the whole-shape error (``bathprint.envs.shape_env``): the return is
    (16 - min(rms^2, 16)) / 0.8^2 with rms the reported error in mm; a diverged episode
    returns -25.

    ## Episode End, Arguments

    As ``WriteShapeEnvV3``.
    """

    env_id = "bathprint/CoilRadius-v2"
