"""``bathprint/BuoyantLayers-v0``: print parts that settle at target heights in a gradient bath."""

from __future__ import annotations

from bathprint.envs.shape_env import ShapeEnv
from bathprint.envs.v0 import BathprintEnvV0
from bathprint.envs.v1 import BathprintEnvV1


class BuoyantLayersEnv(BathprintEnvV0):
    """
    Deprecated: ``bathprint/BuoyantLayers-v1`` is the newest version (making this one warns);
    registered so that results made with it reproduce.

    ## Description

    The paper's density-gradient column (Fig. 3E): the bath's density rises linearly from
    1010 kg/m^3 at the surface to 1050 kg/m^3 at the floor, 125 mm down (0.32 kg/m^3 per
    mm). Co-extruded silicone oil (910 kg/m^3) at inner fraction phi = Q_i / (Q_o + Q_i)
    gives the composite density rho_c = (1 - phi) 1054 + phi 910, so each part of the
    filament settles where the bath is as dense as it is: z = -(rho_c - 1010) / 0.32 mm
    (parts lighter than 1010 float at the surface, parts denser than 1050 rest on the floor).
    The target is 2-4 equal layers along 60 mm of filament, each with a settling height from
    -115 to -15 mm in 10 mm steps (phi from 0.05 to 0.27); the agent sets Q_o and Q_i.
    Settling itself takes minutes and is not simulated: the metric uses the height each part
    will settle at, from its density (exact, per segment, from the simulator's material
    records). The task is close to open loop, the simplest of the three and a sanity check
    for agents: phi = (1054 - rho_target) / 144 follows from the target ahead; what is left is
    to switch at the right printed length (the growing inlet segment averages the density
    over up to two node spacings) with Q_o and Q_i together, since the exit speed (and so the
    time a step takes) depends on both.

    Scene: ``gelation_coiling_22G`` with ``inclusions`` (silicone oil) and the gradient bath
    (``bath.density_kg_m3 = 1010``, ``bath.density_bottom_kg_m3 = 1050``,
    ``bath.depth_mm = 125``), needle at z = -10 mm; spec ``envs/buoyant_layers.toml``.

    ## Action Space

    ``Box(-1, 1, (2,), float32)`` (plus 3 or 2 needle-velocity components with
    ``needle_velocity``), mapped affinely and clipped; a NaN raises ``ValueError``:

    | index | control | physical range |
    |-------|---------|----------------|
    | 0 | Q_o, alginate flow rate | 0.3 - 1.0 ml/min |
    | 1 | Q_i, oil flow rate | 0 - 0.6 ml/min (phi up to 0.67) |
    | 2-4 | needle velocity (optional) | +-10 mm/s |

    A step holds these for the time that prints 1 mm of filament.

    ## Observation Space

    ``Box(-10, 10, (94,), float32)``: the shared layout (see ``CoilRadiusEnv`` and
    ``bathprint.envs.observation.OBS_LAYOUT``); here the useful parts are the printed density
    (slice 54-59) and the target's density aim (every third entry of slice 60-83).

    ## Rewards

    Decrease of the metric (``bathprint.envs.metric``) with only its density term: the
    distance of each sample's settling density (clipped to the bath's 1010-1050 range) to
    the target's, / 8 kg/m^3 (25 mm of height), RMS over the target; samples within 3 mm of
    the needle (still in the growing inlet segment) count ``missing_error`` = 4 (100 mm), and
    no sample counts more. Return = 4 - M_final.

    ## Starting State

    30 mm of pure alginate printed at Q_o = 0.5 ml/min (one of 2 cached warm-ups); the
    target drawn from ``np_random`` (training), the evaluation set, or a file.

    ## Episode End

    Terminated after 60 + 3 mm printed (63 steps); truncated if the simulation diverges
    (``info["sim_error"]``).

    ## Arguments

    As ``CoilRadiusEnv``: ``render_mode``, ``accuracy``, ``needle_velocity``,
    ``target_set``, ``target_index``, ``target_file``, ``scene_overrides``,
    ``spec_overrides``, ``spec_file``.
    """

    env_id = "bathprint/BuoyantLayers-v0"


class BuoyantLayersEnvV1(BathprintEnvV1):
    """
    ## Description

    ``BuoyantLayers-v0`` is a static inverse map (phi from the density the target asks for).
    Here the oil pump responds with a first-order lag (tau = 0.1 s, ``control.inner_lag_s``:
    tubing compliance), so the density follows the command late and smoothly: to print
    layers that settle where the target says, the agent must switch early and by the right
    amount, and the flow rate Q_o sets how much material a lag time spans (4-13 mm). The
    state (the oil flow now) is observed. Targets are printed by this environment from
    random sequences of 2-4 commanded oil fractions (and 1-3 flow sections) through the same
    lag: reachable by construction. ``docs/envs/BuoyantLayers-v1.md``; spec
    ``envs/buoyant_layers_v1.toml``.

    ## Action Space

    ``Box(-1, 1, (2,), float32)``: log Q_o (0.3-1.0 ml/min) and the commanded inner fraction
    phi (0-0.32; density (1 - phi) 1054 + phi 910 kg/m^3).

    ## Observation Space

    ``Box(-10, 10, (83,), float32)``: filament near the tip, printed density, target density
    band (both bounds) from 30 mm behind to 20 mm ahead, the action, the oil fraction now,
    progress; densities as (rho - 1030) / 10 kg/m^3. Goal form: observation (65), goals
    (244: the density band of 121 samples, counts).

    ## Rewards, Episode End, Arguments

    As ``CoilRadiusEnvV1``, with the density-only metric of v0 (settling height error / 25 mm);
    2 + 60 + 3 mm (65 steps); success: M <= 0.25.
    """

    env_id = "bathprint/BuoyantLayers-v1"


class BuoyantLayersEnvV2(ShapeEnv):
    """
    ## Description

    Print a shape of the buoyant family (``bathprint.envs.shapes``): 2-4 parts that settle
    at chosen heights in the gradient bath (1010-1050 kg/m^3 over 125 mm) for training and
    the named validation and test shapes, evenly stepped staircases held out (``ood_test``),
    by the oil fraction of the filament through a pump that follows its command with a
    0.1 s lag (the paper's Fig. 3E). The scene and actions of ``BuoyantLayers-v1``; a 10 mm
    lead-in before the first scored sample lets the pump reach the first part's fraction.
    Each written sample sits at the height where the bath is as dense as it (settling
    takes minutes; the height follows from the density). Scored by the whole-shape error in
    mm after the best rotation about the vertical and horizontal translation
    (``docs/shapes.md``); success: RMS <= 5 mm (no bound on the maximum: the pump's lag).
    ``docs/envs/BuoyantLayers-v2.md``; spec ``envs/buoyant_layers_v2.toml``.

    ## Action Space

    As ``BuoyantLayersEnvV1``: log Q_o (0.3-1.0 ml/min), the commanded inner fraction
    (0-0.32).

    ## Observation Space

    ``Box(-10, 10, (80,), float32)``: the filament near the needle and its densities, the
    target's density band from 30 mm behind to 20 mm ahead, the controls, the oil fraction
    now, progress (``obs_layout``).

    ## Rewards

    Potential-based on the whole-shape error (``bathprint.envs.shape_env``): the return is
    (625 - min(rms^2, 625)) / 5^2 with rms the reported error in mm; a diverged episode
    returns -25.

    ## Episode End, Arguments

    As ``WriteShapeEnvV3``.
    """

    env_id = "bathprint/BuoyantLayers-v2"
