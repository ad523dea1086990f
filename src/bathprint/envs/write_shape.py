"""``bathprint/WriteShape-v0``: write a target 3D curve with the filament."""

from __future__ import annotations

from bathprint.envs.shape_env import ShapeEnv
from bathprint.envs.v0 import BathprintEnvV0
from bathprint.envs.v1 import BathprintEnvV1


class WriteShapeEnv(BathprintEnvV0):
    """
    Deprecated: ``bathprint/WriteShape-v2`` is the newest version (making this one warns);
    registered so that results made with it reproduce.

    ## Description

    The coiling gel filament of ``CoilRadius-v0`` used as a pen: the target is a 3D curve
    made of 2-4 sections of 10, 15 or 20 mm, each a helix (radius 2.5-4.5 mm, pitch 0.5, 2
    or 4 mm), a straight piece or a planar arc (radius 5, 8 or 12 mm), and each free, to
    float or to sink (density below / above the bath's 1051 kg/m^3 by 2 kg/m^3). The agent
    has the flow rates (coil size; co-extruded oil makes the filament lighter and softer), the
    offset of the oil inclusions (which bends the filament: natural curvature
    kappa0 = C Delta phi / r, up to 0.24 1/mm) and, with ``needle_velocity=True``, the
    needle's velocity. Straight pieces and open pitches are out of reach of the flows alone:
    a needle moving at a speed comparable to the extrusion speed lays the filament out (at
    Q_o = 0.25 ml/min, v = 32 mm/s, moving the needle at 20 mm/s brings the median curvature
    of the printed part from 0.18 to 0.12 1/mm in a quick check). Written shapes are
    compared up to rigid motion, window by window.

    Scene: ``gelation_coiling_22G`` with the ``inclusions`` effect (silicone oil, 910 kg/m^3,
    curvature coefficient C = 0.1), needle at z = -10 mm; spec ``envs/write_shape.toml``.

    ## Action Space

    ``Box(-1, 1, (3,), float32)`` (``(6,)`` with ``needle_velocity=True``, ``(5,)`` with
    ``"xy"``), mapped affinely and clipped; a NaN raises ``ValueError``:

    | index | control | physical range |
    |-------|---------|----------------|
    | 0 | Q_o, alginate flow rate | 0.25 - 2.0 ml/min |
    | 1 | Q_i, oil flow rate | 0 - 0.5 ml/min (inner fraction <= 0.9) |
    | 2 | inclusion offset Delta = (r1 - r2) / r | -1 - 1 |
    | 3-5 | needle velocity x, y, z (optional) | +-20 mm/s each |

    The needle tip is kept in the box [-20, 20] x [-20, 20] x [-40, -3] mm.

    A step holds these for the time that prints 1 mm of filament.

    ## Observation Space

    ``Box(-10, 10, (94,), float32)``: the layout shared by all bathprint environments, see
    ``CoilRadiusEnv`` and ``bathprint.envs.observation.OBS_LAYOUT`` (filament near the needle,
    recent curvature and density, target curvature / torsion / density aim from 30 mm behind
    to 20 mm ahead, current controls, progress).

    ## Rewards

    Decrease of the shape metric (``bathprint.envs.metric``): per target sample, windowed
    (15 mm) Kabsch RMS distance / 3 mm, curvature difference x 3 mm (weight 0.5) and distance
    of the density to the sample's band / 10 kg/m^3 (weight 0.5), RMS over the target;
    unscored samples (closer than 20 mm to the needle) count 2. Return = 2 - M_final.

    ## Starting State

    30 mm printed at Q_o = 0.5 ml/min (one of 4 cached warm-ups, drawn from ``np_random``);
    target drawn from ``np_random`` (training), the evaluation set, or a file.

    ## Episode End

    Terminated when the target (20-80 mm) plus 20 mm has been printed; truncated if the
    simulation diverges (``info["sim_error"]``).

    ## Arguments

    As ``CoilRadiusEnv``: ``render_mode``, ``accuracy``, ``needle_velocity``,
    ``target_set``, ``target_index``, ``target_file``, ``scene_overrides``,
    ``spec_overrides``, ``spec_file``.
    """

    env_id = "bathprint/WriteShape-v0"


class WriteShapeEnvV1(BathprintEnvV1):
    """
    Deprecated: ``bathprint/WriteShape-v2`` is the newest version (making this one warns);
    registered so that results made with it reproduce.

    ## Description

    Writing with the needle, as the fluid-rope-trick work of Chaudhary, Christ, Hart &
    Mahadevan (2023) writes with the nozzle: the needle moves horizontally (up to 60 mm/s,
    comparable with the extrusion speed of 32-250 mm/s) and the flow rate sets how fast
    filament comes out, so the filament is laid out straight (needle speed near the
    extrusion speed), in translated loops (slower) or coiled (still). Every target is a
    filament this environment printed from a random smooth sequence of flows (1-3 sections)
    and needle velocities (knots every 10 mm), so it is reachable by construction.
    ``docs/envs/WriteShape-v1.md``; spec ``envs/write_shape_v1.toml``.

    ## Action Space

    ``Box(-1, 1, (3,), float32)``: log Q_o (0.25-2.0 ml/min), needle velocity x and y
    (+-60 mm/s), the tip kept in [-40, 40] x [-40, 40] mm; ``needle_velocity="xyz"`` adds z.

    ## Observation Space

    ``Box(-10, 10, (79,), float32)``: as ``CoilRadiusEnvV1`` plus the needle position in
    its box (2) and 3 action entries; goal form: observation (61), goals (365).

    ## Rewards, Episode End, Arguments

    As ``CoilRadiusEnvV1`` (window 15 mm); success: M <= 0.15.
    """

    env_id = "bathprint/WriteShape-v1"


class WriteShapeEnvV2(BathprintEnvV1):
    """
    ## Description

    ``WriteShape-v1``'s task (the same scene, actions, targets, metric and test sets) with
    the target observed where it lies: the observation adds the target's centreline at 7
    arclength offsets (-10 to 20 mm, every 5 mm) from the sample the needle extrudes now,
    relative to the needle. Version 1 observes the target only by its curvature and torsion,
    which do not say which way it turns (an S and a C have the same curvature), and a policy
    cloned on it scores 0.31-0.36 on the validation targets; with the positions, the same
    cloning scores 0.18-0.19 (``docs/agents.md#writeshape-v2``).
    Episodes start from the target's own start state, so its positions are reachable in the
    bath's frame. ``docs/envs/WriteShape-v2.md``; spec ``envs/write_shape_v2.toml``.

    ## Action Space

    As ``WriteShapeEnvV1``.

    ## Observation Space

    ``Box(-10, 10, (100,), float32)``: ``WriteShapeEnvV1``'s 79 entries, then the target
    positions (21; ``target_positions``, mm / 10); the goal form is version 1's.

    ## Rewards, Episode End, Arguments

    As ``WriteShapeEnvV1``.
    """

    env_id = "bathprint/WriteShape-v2"


class WriteShapeEnvV3(ShapeEnv):
    """
    ## Description

    Write a shape of the floor family (``bathprint.envs.shapes``): single-stroke letters,
    lines, meanders and translated loops for training and the named validation and test
    shapes, digits held out (``ood_test``), with the moving needle, as the fluid-mechanical
    sewing machine writes with its belt (Chiu-Webster & Lister 2006; Brun et al. 2015). The
    scene, actions and episode of ``WriteShape-v2``; the shape is placed to start under the
    needle, turned about the vertical to fit the needle's box. Scored by the whole-shape
    error in mm after the best rotation about the vertical and translation
    (``docs/shapes.md``); success: RMS <= 1.5 mm and max <= 4 mm.
    ``docs/envs/WriteShape-v3.md``; spec ``envs/write_shape_v3.toml``.

    ## Action Space

    As ``WriteShapeEnvV1``: log Q_o (0.25-2.0 ml/min), needle velocity x and y (+-60 mm/s).

    ## Observation Space

    ``Box(-10, 10, (99,), float32)``: the filament near the needle, the target's curvature
    and torsion from 30 mm behind to 20 mm ahead, the controls, the needle's position in its
    box, progress (printed fraction, scored fraction, scored-prefix RMS error / 6 mm) and the
    target's centreline at 7 arclength offsets relative to the needle (``obs_layout``).

    ## Rewards

    Potential-based on the whole-shape error (``bathprint.envs.shape_env``): the return is
    (36 - min(rms^2, 36)) / 1.5^2 with rms the reported error in mm; a diverged episode
    returns -16.

    ## Episode End, Arguments

    Terminated when the shape plus 20 mm has been printed; truncated if the simulation
    diverges. Arguments: ``render_mode``, ``accuracy``, ``target_set`` (``train``,
    ``validation``, ``test``, ``ood_test``), ``target_index``, ``target_file`` (a shape
    CSV), ``scene_overrides``, ``spec_overrides``, ``spec_file``.
    """

    env_id = "bathprint/WriteShape-v3"
