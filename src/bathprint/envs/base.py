"""What every environment version shares: :class:`BathprintEnvBase` and the step's physics.

Each version is its own class (``v0.BathprintEnvV0``, ``v1.BathprintEnvV1``) on this base;
no version inherits another's behaviour. The base holds only machinery every version uses
unchanged and none overrides: the scene and its constants, the cached warm-up states, the
reading of the simulation, rendering, and the deprecation warning of a superseded version.
The physics of a step is in plain functions: :func:`set_flows` (the step's duration),
:func:`move_needle_within` and :func:`advance_to`.

A step prints a fixed length of filament (``control.length_mm``) at the flow rates the
action sets: the simulator is advanced by exactly the time that extrudes that length.
"""

from __future__ import annotations

import hashlib
import json
import math
import pickle
import sys
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np

from bathprint.core import layout as L
from bathprint.core.simulation import Simulation
from bathprint.envs._kernels import interp_rows, read_state
from bathprint.envs.accuracy import ACCURACY_PRESETS, accuracy_overrides
from bathprint.envs.needle import move_needle
from bathprint.envs.spec import EnvSpecData
from bathprint.errors import ConfigError, SceneError, SimulationError

ML_MIN = 1e-6 / 60.0  # m^3/s per ml/min
MM = 1e-3  # m per mm
RAMP_S = 1e-6  # Simulation.set_flow ramps to the new flow over 1 us
RENDER_MODES = ("human", "rgb_array")


class SceneConfigError(ConfigError, SceneError):
    """A scene an environment's arguments (or spec) make is invalid: a ConfigError naming
    ``scene_overrides``, and still a SceneError."""


# ------------------------------------------------------------------------ argument checks
def check_render_mode(render_mode: Any) -> None:
    if render_mode is not None and not (
        isinstance(render_mode, str) and render_mode in RENDER_MODES
    ):
        raise ConfigError(
            f"render_mode = {render_mode!r}; allowed: None, " + ", ".join(map(repr, RENDER_MODES))
        )


def check_accuracy(accuracy: Any) -> None:
    if not isinstance(accuracy, str) or accuracy not in ACCURACY_PRESETS:
        raise ConfigError(
            f"accuracy = {accuracy!r}; allowed: " + ", ".join(map(repr, ACCURACY_PRESETS))
        )


def check_needle_velocity(needle_velocity: Any) -> None:
    """The needle axes an environment of version 1 on adds to its action (None: the spec's)."""
    if not (
        needle_velocity is None
        or isinstance(needle_velocity, bool)
        or (isinstance(needle_velocity, str) and needle_velocity in ("xy", "xyz"))
    ):
        raise ConfigError(
            f"needle_velocity = {needle_velocity!r}; allowed: None (the spec's default), "
            "False, True (= 'xyz'), 'xy', 'xyz'"
        )


def check_scene_overrides(scene_overrides: Any) -> None:
    if scene_overrides is not None and not (
        isinstance(scene_overrides, dict) and all(isinstance(k, str) for k in scene_overrides)
    ):
        raise ConfigError(
            f"scene_overrides = {scene_overrides!r}; allowed: None or a mapping of dotted "
            "scene keys to values, e.g. {'bath.viscosity_pa_s': 1.0}"
        )


def is_index(x: Any) -> bool:
    """An integer (numpy's too), not a bool."""
    return isinstance(x, int | np.integer) and not isinstance(x, bool)


# ------------------------------------------------------------------------ scene
@dataclass(frozen=True)
class SceneConstants:
    """The scene of an environment and the constants the environment reads from it."""

    base: str  # scene name
    overrides: dict[str, Any]  # dotted keys: the spec's, the preset's, the caller's, the flow
    warmup_q_outer: float  # ml/min
    needle_area: float  # m^2
    rho_gel: float  # kg/m^3, the alginate's exit density
    phi_max: float  # largest inner (oil) fraction
    has_inclusions: bool
    needle_start_mm: np.ndarray  # (3,)
    needle_direction: np.ndarray  # (3,) unit
    depth_mm: float
    bath_range: tuple[float, float] | None  # densities at the top and floor (gradient bath)
    rho_bath_needle: float  # kg/m^3, the bath's density at the needle's start


def scene_constants(
    spec_data: EnvSpecData, accuracy: str, scene_overrides: dict[str, Any] | None
) -> SceneConstants:
    """The scene of a spec with the accuracy preset and ``scene_overrides`` applied last (the
    flow set to the warm-up's), validated by making it once."""
    ep = spec_data.episode
    warmup_q_outer = float(ep.get("warmup_q_outer_ml_min", 0.5))
    overrides: dict[str, Any] = dict(spec_data.scene.get("overrides", {}))
    overrides.update(accuracy_overrides(accuracy))
    overrides.update(scene_overrides or {})
    overrides.update(
        {"flow.schedule": [], "flow.q_outer_ml_min": warmup_q_outer, "flow.q_inner_ml_min": 0.0}
    )
    base = str(spec_data.scene.get("base", "gelation_coiling_22G"))
    try:
        probe = Simulation(base, overrides)  # validates the scene
    except SceneError as exc:
        raise SceneConfigError(
            f"scene {base!r} with the spec's overrides and scene_overrides = "
            f"{scene_overrides!r}: {exc}"
        ) from exc
    m = probe.model
    needle_start_mm = np.array(m.needle[0, 1:4] / MM)
    grad = float(m.p.bath_density_gradient)  # kg/m^3 per m of depth
    rho_top = float(m.p.bath_density_top)
    depth_m = -float(m.p.floor_z)
    return SceneConstants(
        base=base,
        overrides=overrides,
        warmup_q_outer=warmup_q_outer,
        needle_area=m.needle_area,
        rho_gel=float(m.p.exit_density),
        phi_max=float(probe.scene.inclusions.max_inner_fraction),
        has_inclusions=bool(m.p.inclusions),
        needle_start_mm=needle_start_mm,
        needle_direction=np.array(m.needle[0, 4:7]),
        depth_mm=depth_m / MM,
        bath_range=(rho_top, rho_top + grad * depth_m) if grad > 0 else None,
        rho_bath_needle=rho_top + grad * max(-needle_start_mm[2] * MM, 0.0),
    )


# Warm-up states are the same for every instance with the same scene: computed once per
# process and kept pickled (a Simulation pickles; loading one takes ~0.2 ms).
_START_STATES: dict[str, bytes] = {}


def start_state(scene: SceneConstants, warmup_length_mm: float, index: int) -> bytes:
    """Pickled warm-up state number ``index`` (needle imperfection seed + index): the scene
    run at the warm-up flow until ``warmup_length_mm`` of filament is printed."""
    seed = int(scene.overrides.get("seed", 0)) + index
    key_src = json.dumps(
        [scene.base, scene.overrides, seed, warmup_length_mm], sort_keys=True, default=str
    )
    key = hashlib.sha1(key_src.encode()).hexdigest()
    if key not in _START_STATES:
        ov = dict(scene.overrides)
        ov["seed"] = seed
        v = scene.warmup_q_outer * ML_MIN / scene.needle_area  # m/s
        total_mm = warmup_length_mm + 200.0  # capacity estimate only (arrays grow)
        ov["duration_s"] = total_mm * MM / v
        sim = Simulation(scene.base, ov)
        sim.advance(warmup_length_mm * MM / v)
        _START_STATES[key] = pickle.dumps(sim)
    return _START_STATES[key]


# ------------------------------------------------------------------------ a step's physics
def set_flows(
    sim: Simulation, qo: float, qi: float, old_qo: float, old_qi: float, volume_m3: float
) -> float:
    """Set the flows (ml/min; only if they change) and return the time (s) that extrudes
    ``volume_m3`` from now: the 1 us ramp extrudes (q_old + q_new)/2 * 1 us, the rest flows
    at q_new."""
    q_new = (qo + qi) * ML_MIN
    if qo != old_qo or qi != old_qi:
        q_old = (old_qo + old_qi) * ML_MIN
        sim.set_flow(qo * ML_MIN, qi * ML_MIN)
        return RAMP_S + (volume_m3 - 0.5 * (q_old + q_new) * RAMP_S) / q_new
    return volume_m3 / q_new


def move_needle_within(
    sim: Simulation,
    needle_mm: np.ndarray,
    vel_mm_s: np.ndarray,
    dt: float,
    box_mm: np.ndarray,
    t_end: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Move the needle at ``vel_mm_s`` for ``dt`` s, stopping at the box (rows: axes, columns:
    low, high; mm). Returns its new position (mm) and the velocity it moved at (mm/s)."""
    goal = np.clip(needle_mm + vel_mm_s * dt, box_mm[:, 0], box_mm[:, 1])
    vel = (goal - needle_mm) / dt
    move_needle(sim, vel * MM, t_end)
    return goal, vel


def advance_to(sim: Simulation, t_end: float, max_substeps: int) -> None:
    """Advance to ``t_end`` (s) within ``max_substeps`` integrator steps; a SimulationError if
    the simulation diverges or the budget runs out first."""
    sim.advance(t_end, max_steps=max_substeps)
    if sim.t < t_end - 1e-12 * max(1.0, t_end):
        raise SimulationError(
            f"step budget used up ({max_substeps} integrator steps for one "
            "environment step; episode.max_substeps)",
            sim.t,
            -1,
        )


# ------------------------------------------------------------------------ the base class
class BathprintEnvBase(gym.Env[Any, np.ndarray]):
    """The machinery every version shares (final: no version overrides a method of it).

    A version provides ``reset``, ``step``, ``episode_length_mm`` and the target logic; it
    calls :meth:`_init_scene` in its constructor and :meth:`_snapshot` after each advance.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": list(RENDER_MODES), "render_fps": 10}
    env_id: ClassVar[str] = ""

    # set by the version's constructor
    spec_data: EnvSpecData
    warmup_length_mm: float
    observes_density: bool

    # ------------------------------------------------------------------ construction
    def _warn_if_superseded(self) -> None:
        """A DeprecationWarning naming the newest version when this one is older (pointing
        at the caller's line, outside gymnasium and bathprint.envs)."""
        from bathprint.envs import newest_id

        newest = newest_id(self.env_id) if self.env_id else self.env_id
        if newest == self.env_id:
            return
        warnings.warn(
            f"{self.env_id} is deprecated: {newest} is the newest version of this "
            f"environment (docs/envs/, Version History); {self.env_id} stays registered to "
            "reproduce results made with it",
            DeprecationWarning,
            stacklevel=_caller_stacklevel(),
        )

    def _init_scene(self, accuracy: str, scene_overrides: dict[str, Any] | None) -> None:
        """The scene and its constants as attributes (see :class:`SceneConstants`)."""
        sc = scene_constants(self.spec_data, accuracy, scene_overrides)
        self.scene = sc
        self.warmup_q_outer = sc.warmup_q_outer
        self.scene_base = sc.base
        self.scene_overrides = sc.overrides
        self.needle_area = sc.needle_area  # m^2
        self.rho_gel = sc.rho_gel
        self.phi_max = sc.phi_max
        self.has_inclusions = sc.has_inclusions
        self.needle_start_mm = sc.needle_start_mm
        self.needle_direction = sc.needle_direction
        self.depth_mm = sc.depth_mm
        self.bath_range = sc.bath_range
        self.rho_bath_needle = sc.rho_bath_needle

    def _start_state(self, index: int) -> bytes:
        """Pickled warm-up state number ``index`` (cached per process)."""
        return start_state(self.scene, self.warmup_length_mm, index)

    # ------------------------------------------------------------------ state -> numbers
    def _snapshot(self) -> None:
        """Read the simulation once per step: positions (mm), material coordinate u (mm from
        the free end), velocities (mm/s), densities (only where the environment observes or
        scores them: else one stand-in value) and the length printed since the reset."""
        sim = self.sim
        assert sim is not None
        x, v = sim.centerline(), sim.velocities()
        u, finite = read_state(x, v, sim.rest_lengths(), MM)  # x, v: m -> mm in place
        if not finite:
            raise SimulationError("non-finite state read by the environment", sim.t, -1)
        self._x, self._u, self._v = x, u, v
        if self.observes_density:
            self._rho = np.ascontiguousarray(sim.material()[:, L.MAT_DENSITY])
        else:
            self._rho = np.array([self.rho_gel])
        self._printed_mm = float(u[-1] - self._u0_mm)

    def _interp(self, u_query: np.ndarray, values: np.ndarray) -> np.ndarray:
        """Rows of ``values`` (one per node) at material coordinates ``u_query`` (mm)."""
        out = np.empty((len(u_query), values.shape[1]))
        interp_rows(self._u, values, np.ascontiguousarray(u_query, np.float64), out)
        return out

    @property
    def episode_length_mm(self) -> float:  # each version says what an episode prints
        raise NotImplementedError

    @property
    def episode_steps(self) -> int:
        """Steps of a full episode (the environment terminates after this many)."""
        return int(math.ceil(self.episode_length_mm / self.control_length_mm - 1e-9))

    # ------------------------------------------------------------------ rendering
    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gym.logger.warn(
                "render() called without a render_mode; pass render_mode='rgb_array' or 'human'"
            )
            return None
        from bathprint.envs.render import draw, show

        frame = draw(self)
        if self.render_mode == "rgb_array":
            return frame
        show(self, frame)
        return None

    def close(self) -> None:
        if getattr(self, "_window", None) is not None:
            from bathprint.envs.render import close

            close(self)
        self._figure = None
        super().close()


def check_path(value: Any, name: str, what: str) -> None:
    """``value`` is None or a path to an existing file."""
    if value is None:
        return
    if not isinstance(value, str | Path):
        raise ConfigError(f"{name} = {value!r}; allowed: {what}")
    if not Path(value).is_file():
        raise ConfigError(f"{name} = {str(value)!r} does not exist")


def _caller_stacklevel() -> int:
    """The stacklevel of the first frame outside gymnasium and bathprint.envs (the line that
    made the environment), counted from the caller of ``warnings.warn``."""
    frame = sys._getframe(2)  # the caller of _warn_if_superseded: stacklevel 2
    level = 2
    while frame is not None:
        name = frame.f_globals.get("__name__", "")
        if not (name.startswith(("gymnasium", "bathprint.envs")) or name == __name__):
            return level
        frame = frame.f_back
        level += 1
    return 2
