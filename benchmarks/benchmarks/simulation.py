"""The simulator's speed: the default scene, each effect's cost, the cost per step against
the number of nodes, and the fixed cost of a call."""

from __future__ import annotations

import time

from bathprint import Simulation

SCENE = "paper_simulation"


def _wall(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


class DefaultScene:
    """The default scene (``paper_simulation``), adaptive steps."""

    timeout = 600
    duration_s = 1.0

    def setup(self) -> None:
        Simulation(SCENE).advance(0.01)  # compile (or load the numba cache)

    def track_wall_s_per_simulated_s(self) -> float:
        """Wall seconds per simulated second over the scene's first second."""
        sim = Simulation(SCENE, {"duration_s": self.duration_s})
        return _wall(lambda: sim.advance(self.duration_s)) / self.duration_s

    track_wall_s_per_simulated_s.unit = "s/s"


class EffectCost:
    """Each optional effect's cost: wall time per Newton iteration of the default scene at
    fixed 2 ms steps with the effect added, over that of elasticity and drag alone, both
    measured in the same call (a ratio: the machine's speed cancels)."""

    timeout = 600
    params = ["gravity", "floor", "inertia", "viscosity", "gelation", "inclusions"]
    param_names = ["effect"]
    simulated_s = 0.2
    base = ["elasticity", "drag"]

    def _scene(self, effects: list[str]) -> dict:
        over = {"effects": effects, "duration_s": 1.0, "numerics.time_step_s": 2e-3}
        if "inclusions" in effects:
            over["flow.q_inner_ml_min"] = 2.0
        return over

    def setup(self, effect: str) -> None:
        for effects in (self.base, self.base + [effect]):
            Simulation(SCENE, self._scene(effects)).advance(0.01)  # compile

    def _per_iteration(self, effects: list[str]) -> float:
        sim = Simulation(SCENE, self._scene(effects))
        wall = _wall(lambda: sim.advance(self.simulated_s))
        return wall / sim.counts()["newton_iterations"]

    def track_cost_per_iteration_over_base(self, effect: str) -> float:
        return self._per_iteration(self.base + [effect]) / self._per_iteration(self.base)

    track_cost_per_iteration_over_base.unit = "ratio"


def _sagging_filament(n: int) -> Simulation:
    """A clamped horizontal filament of n segments of 0.5 mm sagging under its net weight,
    fixed 2 ms steps (the state of experiments/scaling)."""
    return Simulation(
        SCENE,
        {
            "flow.q_outer_ml_min": 0.0,
            "initial.length_mm": n * 0.5,
            "numerics.node_spacing_mm": 0.5,
            "needle.direction": [1.0, 0.0, 0.0],
            "initial.perturbation_mm": 1.0,
            "numerics.time_step_s": 2e-3,
            "duration_s": 100.0,
        },
    )


class StepCostVsNodes:
    """Cost per step against N: the wall time of a step of N nodes over N/100 times that of
    100 nodes, both measured in the same call (1 when the cost grows linearly)."""

    timeout = 600
    params = [1000, 10000]
    param_names = ["nodes"]
    steps = 10

    def setup(self, nodes: int) -> None:
        self.sims = {}
        for n in (100, nodes):
            sim = _sagging_filament(n)
            sim.advance(0.02)  # compile, and leave the start-up transient
            self.sims[n] = sim

    def _per_step(self, n: int) -> float:
        sim = self.sims[n]
        return _wall(lambda: sim.advance(sim.t + self.steps * 2e-3)) / self.steps

    def track_step_cost_over_linear(self, nodes: int) -> float:
        return self._per_step(nodes) / (self._per_step(100) * nodes / 100)

    track_step_cost_over_linear.unit = "ratio"


class CallOverhead:
    """The fixed cost of a call into the time loop that takes no step (what a short call,
    as an environment's control step, pays on top of its steps)."""

    def setup(self) -> None:
        self.sim = Simulation(SCENE)
        self.sim.advance(0.01)
        self.sim.advance(self.sim.t)  # the first call without a step sets up (~10 ms)

    def time_advance_without_a_step(self) -> None:
        self.sim.advance(self.sim.t)
