"""The observation's units and sampling offsets, shared by every environment version.

Every version observes the filament near the needle at the same material offsets behind the
tip and in the same units; which blocks an observation holds, and in what order, is each
version's own (:data:`OBS_LAYOUT` is version 0's, version 1 builds its layout per
environment). Positions are divided by :data:`OBS_LENGTH_MM` (10 mm), velocities by
:data:`OBS_SPEED_MM_S` (100 mm/s), curvatures multiplied by :data:`OBS_CURVATURE_MM` (3 mm),
densities given as (rho - 1054) / 50 kg/m^3 unless a spec says otherwise; every entry is
clipped to +-:data:`OBS_CLIP` (10).
"""

from __future__ import annotations

import numpy as np

OBS_LENGTH_MM = 10.0  # positions are divided by this
OBS_SPEED_MM_S = 100.0  # velocities are divided by this
OBS_CURVATURE_MM = 3.0  # curvatures (1/mm) are multiplied by this
OBS_DENSITY_REF_KG_M3 = 1054.0  # densities are given as (rho - ref) / scale
OBS_DENSITY_SCALE_KG_M3 = 50.0
OBS_NEEDLE_MM = 10.0  # needle displacement is divided by this (version 0)
OBS_CLIP = 10.0  # every entry is clipped to [-OBS_CLIP, OBS_CLIP]

TIP_OFFSETS_MM = (1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 10.0, 13.0, 16.0, 20.0, 25.0, 30.0)
VEL_OFFSETS_MM = (2.0, 6.0, 13.0, 25.0)
CURV_OFFSETS_MM = (4.0, 8.0, 13.0, 18.0, 25.0, 30.0)
DENS_OFFSETS_MM = (0.5, 2.0, 5.0, 10.0, 20.0, 30.0)
TARGET_OFFSETS_MM = (-30.0, -20.0, -10.0, 0.0, 5.0, 10.0, 15.0, 20.0)
RECENT_SAMPLES = 10  # the progress block's "last samples" error spans this many samples

BACK_STEP_MM = 0.5  # sampling of the filament behind the tip for its curvature
BACK_MM = np.arange(0.0, max(CURV_OFFSETS_MM) + 2.0 + 1e-9, BACK_STEP_MM)
#: all material coordinates (mm behind the tip) an observation interpolates, in one query:
#: the tip offsets, the velocity offsets, then the curvature's back sampling
QUERY_MM = np.concatenate([TIP_OFFSETS_MM, VEL_OFFSETS_MM, BACK_MM])
QUERY_TIP = slice(0, len(TIP_OFFSETS_MM))
QUERY_VEL = slice(QUERY_TIP.stop, QUERY_TIP.stop + len(VEL_OFFSETS_MM))
QUERY_BACK = slice(QUERY_VEL.stop, QUERY_VEL.stop + len(BACK_MM))
#: rows of the back sampling at the curvature offsets
CURV_INDEX = np.round(np.array(CURV_OFFSETS_MM) / BACK_STEP_MM).astype(np.int64)

#: version 0's observation (the same in its three environments): block name, size
OBS_LAYOUT: tuple[tuple[str, int], ...] = (
    ("tip_relative_positions", 3 * len(TIP_OFFSETS_MM)),
    ("velocities", 3 * len(VEL_OFFSETS_MM)),
    ("printed_curvature", len(CURV_OFFSETS_MM)),
    ("printed_density", len(DENS_OFFSETS_MM)),
    ("target_curvature_torsion_density", 3 * len(TARGET_OFFSETS_MM)),
    ("controls", 6),
    ("progress", 4),
)
OBS_SIZE = sum(n for _, n in OBS_LAYOUT)

#: version 0's layout as its observation kernel takes it (bathprint.envs._kernels.observe)
KERNEL_LAYOUT_V0 = (
    QUERY_MM,
    len(TIP_OFFSETS_MM),
    len(VEL_OFFSETS_MM),
    CURV_INDEX,
    np.array(DENS_OFFSETS_MM),
    np.array(TARGET_OFFSETS_MM),
    np.array(
        [
            OBS_LENGTH_MM,
            OBS_SPEED_MM_S,
            OBS_CURVATURE_MM,
            OBS_DENSITY_REF_KG_M3,
            OBS_DENSITY_SCALE_KG_M3,
        ]
    ),
    RECENT_SAMPLES,
)


def layout_slices(layout: tuple[tuple[str, int], ...]) -> dict[str, slice]:
    """Block name -> slice of an observation vector with this layout."""
    out, k = {}, 0
    for name, n in layout:
        out[name] = slice(k, k + n)
        k += n
    return out


def obs_slices() -> dict[str, slice]:
    """Name -> slice of version 0's observation vector."""
    return layout_slices(OBS_LAYOUT)


def to_unit(x: float, lo: float, hi: float) -> float:
    """``x`` in [lo, hi] mapped affinely to [-1, 1] (0 for an empty range), unclipped."""
    return 0.0 if hi <= lo else 2.0 * (x - lo) / (hi - lo) - 1.0
