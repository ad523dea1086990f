"""bathprint against PyElastica on the cantilever in water with inertia (the problem of
experiments/pyelastica): PyElastica's wall time over bathprint's for 0.5 s of the lightly
damped oscillation at 50 elements, each at a setting of about equal error in
experiments/pyelastica/results/pyelastica.csv (PyElastica's PositionVerlet at its largest
stable step, 3.85e-5 s: error 3.1e-4; bathprint's SDIRK4 at a fixed 0.625 ms: 1.4e-4).
Skipped where PyElastica (the ``bench`` extra) is not installed."""

from __future__ import annotations

import contextlib
import io
import math
import time

import numpy as np

from bathprint import Simulation

ELEMENTS = 50
T_END = 0.5  # s
PE_DT = 3.84615e-05  # s, PyElastica's largest stable step at 50 elements
BP_STEP = 0.000625  # s, bathprint's SDIRK4 fixed step
LENGTH, RADIUS, YOUNGS = 10e-3, 0.5e-3, 5e4  # m, m, Pa
RHO, RHO_BATH, MU, GRAVITY = 1006.0, 1003.0, 1e-3, 9.81
MU_S = 2.0 * math.pi * MU / math.log(20e-3 / RADIUS)  # Pa s, Cox's drag with L = 20 mm


def _bathprint_wall() -> float:
    sim = Simulation(
        "cantilever_water",
        {
            "effects": ["elasticity", "drag", "gravity", "inertia"],
            "numerics.node_spacing_mm": LENGTH * 1e3 / ELEMENTS,
            "numerics.integrator": "sdirk4",
            "numerics.time_step_s": BP_STEP,
        },
    )
    t0 = time.perf_counter()
    sim.advance(T_END)
    return time.perf_counter() - t0


def _pyelastica_wall() -> float:
    import elastica as ea
    from numba import njit

    @njit(cache=True)
    def drag(vel, tangents, lengths, mu_s, out):
        for j in range(lengths.shape[0]):
            half = 0.5 * mu_s * lengths[j]
            for i in (j, j + 1):
                ut = vel[0, i] * tangents[0, j] + vel[1, i] * tangents[1, j]
                ut += vel[2, i] * tangents[2, j]
                for a in range(3):
                    out[a, i] -= half * (2.0 * vel[a, i] - ut * tangents[a, j])

    class Drag(ea.NoForces):
        def apply_forces(self, system, time: float = 0.0) -> None:
            drag(
                system.velocity_collection,
                system.tangents,
                system.lengths,
                MU_S,
                system.external_forces,
            )

    class Sim(ea.BaseSystemCollection, ea.Constraints, ea.Forcing):
        pass

    sim = Sim()
    rod = ea.CosseratRod.straight_rod(
        ELEMENTS,
        np.zeros(3),
        np.array([1.0, 0.0, 0.0]),
        np.array([0.0, 0.0, 1.0]),
        LENGTH,
        RADIUS,
        RHO + RHO_BATH,
        youngs_modulus=YOUNGS,
        shear_modulus=YOUNGS / 3.0,
    )
    sim.append(rod)
    sim.constrain(rod).using(
        ea.OneEndFixedBC, constrained_position_idx=(0,), constrained_director_idx=(0,)
    )
    g_eff = GRAVITY * (RHO - RHO_BATH) / (RHO + RHO_BATH)
    sim.add_forcing_to(rod).using(ea.GravityForces, acc_gravity=np.array([0.0, 0.0, -g_eff]))
    sim.add_forcing_to(rod).using(Drag)
    sim.finalize()
    n_steps = int(round(T_END / PE_DT))
    with contextlib.redirect_stdout(io.StringIO()), np.errstate(all="ignore"):
        t0 = time.perf_counter()
        ea.integrate(ea.PositionVerlet(), sim, n_steps * PE_DT, n_steps, progress_bar=False)
        return time.perf_counter() - t0


class PyElasticaRatio:
    timeout = 900
    number = 1
    repeat = 1

    def setup(self) -> None:
        try:
            import elastica  # noqa: F401
        except ImportError as e:
            raise NotImplementedError("PyElastica is not installed (pip install .[bench])") from e
        _bathprint_wall()  # compile both
        _pyelastica_wall()

    def track_pyelastica_wall_over_bathprint(self) -> float:
        return _pyelastica_wall() / _bathprint_wall()

    track_pyelastica_wall_over_bathprint.unit = "ratio"
