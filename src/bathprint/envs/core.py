"""The machinery shared by the bathprint environments: :class:`BathprintEnv`.

Each environment (one file each: ``coil_radius.py``, ``write_shape.py``,
``buoyant_layers.py``) is this class with its spec file (``envs/*.toml``) and its docstring.
A step prints a fixed length of filament (``control.length_mm``) at the flow rates the
action sets: the simulator is advanced by exactly the time that extrudes that length.
"""

from __future__ import annotations

import hashlib
import json
import math
import pickle
from pathlib import Path
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from bathprint.core import layout as L
from bathprint.core.simulation import Simulation
from bathprint.envs._kernels import interp_rows, observe, printed_at, read_state
from bathprint.envs.accuracy import ACCURACY_PRESETS, accuracy_overrides
from bathprint.envs.metric import (
    MetricParams,
    MetricValue,
    PreparedMetric,
    PrintedSamples,
    evaluate_prepared,
    prepare,
)
from bathprint.envs.needle import move_needle
from bathprint.envs.spec import EnvSpecData, load_spec
from bathprint.envs.targets import (
    CoilScheduleFamily,
    LayersFamily,
    SectionsFamily,
    Target,
    TargetSampler,
    load_target_file,
)
from bathprint.errors import ConfigError, SceneError, SimulationError

ML_MIN = 1e-6 / 60.0  # m^3/s per ml/min
MM = 1e-3  # m per mm
RAMP_S = 1e-6  # Simulation.set_flow ramps to the new flow over 1 us

# --- observation layout (the same for every environment) ------------------------------
OBS_LENGTH_MM = 10.0  # positions are divided by this
OBS_SPEED_MM_S = 100.0  # velocities are divided by this
OBS_CURVATURE_MM = 3.0  # curvatures (1/mm) are multiplied by this
OBS_DENSITY_REF_KG_M3 = 1054.0  # densities are given as (rho - ref) / scale
OBS_DENSITY_SCALE_KG_M3 = 50.0
OBS_NEEDLE_MM = 10.0  # needle displacement is divided by this
OBS_CLIP = 10.0  # every entry is clipped to [-OBS_CLIP, OBS_CLIP]

TIP_OFFSETS_MM = (1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 10.0, 13.0, 16.0, 20.0, 25.0, 30.0)
VEL_OFFSETS_MM = (2.0, 6.0, 13.0, 25.0)
CURV_OFFSETS_MM = (4.0, 8.0, 13.0, 18.0, 25.0, 30.0)
DENS_OFFSETS_MM = (0.5, 2.0, 5.0, 10.0, 20.0, 30.0)
TARGET_OFFSETS_MM = (-30.0, -20.0, -10.0, 0.0, 5.0, 10.0, 15.0, 20.0)
RECENT_SAMPLES = 10
_BACK_STEP_MM = 0.5  # sampling of the filament behind the tip for its curvature
_BACK_MM = np.arange(0.0, max(CURV_OFFSETS_MM) + 2.0 + 1e-9, _BACK_STEP_MM)
# all material coordinates (behind the tip) the observation interpolates, in one query
_OBS_QUERY_MM = np.concatenate([TIP_OFFSETS_MM, VEL_OFFSETS_MM, _BACK_MM])
_OBS_TIP = slice(0, len(TIP_OFFSETS_MM))
_OBS_VEL = slice(_OBS_TIP.stop, _OBS_TIP.stop + len(VEL_OFFSETS_MM))
_OBS_BACK = slice(_OBS_VEL.stop, _OBS_VEL.stop + len(_BACK_MM))
_OBS_CURV_INDEX = np.round(np.array(CURV_OFFSETS_MM) / _BACK_STEP_MM).astype(np.int64)
# the layout as the observation kernel takes it (bathprint.envs._kernels.observe)
_OBS_KERNEL_LAYOUT = (
    _OBS_QUERY_MM,
    len(TIP_OFFSETS_MM),
    len(VEL_OFFSETS_MM),
    _OBS_CURV_INDEX,
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


def obs_slices() -> dict[str, slice]:
    """Name -> slice of the observation vector."""
    out, k = {}, 0
    for name, n in OBS_LAYOUT:
        out[name] = slice(k, k + n)
        k += n
    return out


class SceneConfigError(ConfigError, SceneError):
    """A scene an environment's arguments (or spec) make is invalid: a ConfigError naming
    ``scene_overrides``, and still a SceneError."""


def _check_index_type(index: Any, name: str = "target_index") -> None:
    if isinstance(index, bool) or not isinstance(index, int | np.integer):
        raise ConfigError(f"{name} = {index!r}; allowed: an integer (an evaluation target)")


# Warm-up states are the same for every instance with the same scene: computed once per
# process and kept pickled (a Simulation pickles; loading one takes ~0.2 ms).
_START_STATES: dict[str, bytes] = {}


class BathprintEnv(gym.Env[np.ndarray, np.ndarray]):
    """Base class; see the subclasses' docstrings for the environments themselves."""

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["human", "rgb_array"], "render_fps": 10}
    env_id: ClassVar[str] = ""

    def __init__(
        self,
        render_mode: str | None = None,
        *,
        accuracy: str = "balanced",
        needle_velocity: bool | str = False,
        target_set: str = "train",
        target_index: int | None = None,
        target_file: str | None = None,
        scene_overrides: dict[str, Any] | None = None,
        spec_overrides: dict[str, Any] | None = None,
        spec_file: str | None = None,
    ) -> None:
        if render_mode is not None and (
            not isinstance(render_mode, str) or render_mode not in self.metadata["render_modes"]
        ):
            raise ConfigError(
                f"render_mode = {render_mode!r}; allowed: None, "
                + ", ".join(repr(m) for m in self.metadata["render_modes"])
            )
        if target_set not in ("train", "eval"):
            raise ConfigError(f"target_set = {target_set!r}; allowed: 'train', 'eval'")
        if not isinstance(accuracy, str) or accuracy not in ACCURACY_PRESETS:
            raise ConfigError(
                f"accuracy = {accuracy!r}; allowed: " + ", ".join(map(repr, ACCURACY_PRESETS))
            )
        if scene_overrides is not None and not (
            isinstance(scene_overrides, dict) and all(isinstance(k, str) for k in scene_overrides)
        ):
            raise ConfigError(
                f"scene_overrides = {scene_overrides!r}; allowed: None or a mapping of dotted "
                "scene keys to values, e.g. {'bath.viscosity_pa_s': 1.0}"
            )
        if target_file is not None:
            if not isinstance(target_file, str | Path):
                raise ConfigError(
                    f"target_file = {target_file!r}; allowed: a path to a CSV or NPY polyline"
                )
            if not Path(target_file).is_file():
                raise ConfigError(f"target_file = {str(target_file)!r} does not exist")
        if spec_file is not None:
            if not isinstance(spec_file, str | Path):
                raise ConfigError(f"spec_file = {spec_file!r}; allowed: a path to a spec TOML")
            if not Path(spec_file).is_file():
                raise ConfigError(f"spec_file = {str(spec_file)!r} does not exist")
        if target_index is not None:
            _check_index_type(target_index)
            if target_set != "eval":
                raise ConfigError(
                    f"target_index = {target_index!r} selects an evaluation target: use "
                    "target_set='eval'"
                )
            if target_file is not None:
                raise ConfigError(
                    f"target_index = {target_index!r} and target_file = {target_file!r}: a "
                    "target file is the only target; give one of them"
                )
        self.render_mode = render_mode
        self.accuracy = accuracy
        self.target_set = target_set
        self.spec_data: EnvSpecData = load_spec(
            None if spec_file else self.env_id, spec_file, spec_overrides
        )
        sd = self.spec_data
        ctl, ep = sd.control, sd.episode

        self._init_scene(accuracy, scene_overrides)

        # --- controls ------------------------------------------------------------------
        self.control_length_mm = float(ctl["length_mm"])
        self.q_outer_range = tuple(float(x) for x in ctl["q_outer_ml_min"])
        self.q_inner_range = tuple(float(x) for x in ctl.get("q_inner_ml_min", [0.0, 0.0]))
        self.offset_range = tuple(float(x) for x in ctl.get("inclusion_offset", [0.0, 0.0]))
        self.action_names: list[str] = list(ctl["actions"])
        if self.q_inner_range[1] > 0 and "q_inner" in self.action_names and not self.has_inclusions:
            raise ConfigError(
                f"{self.env_id}: control.q_inner_ml_min > 0 needs the 'inclusions' effect"
            )
        if needle_velocity is True:
            needle_velocity = "xyz"
        if not (needle_velocity in (False, None) or needle_velocity in ("xy", "xyz")):
            raise ConfigError(
                f"needle_velocity = {needle_velocity!r}; allowed: False, True, 'xy', 'xyz'"
            )
        self.needle_axes = "" if not needle_velocity else str(needle_velocity)
        self.action_names += [f"needle_v{a}" for a in self.needle_axes]
        self._action_index = {name: k for k, name in enumerate(self.action_names)}
        self.needle_speed_mm_s = float(ctl.get("needle_speed_mm_s", 10.0))
        box = np.array(ctl.get("needle_box_mm", [[-20, 20], [-20, 20], [-40, -2]]), float)
        self.needle_box_mm = box.reshape(3, 2)
        self.action_space = spaces.Box(-1.0, 1.0, (len(self.action_names),), np.float32)
        self.observation_space = spaces.Box(-OBS_CLIP, OBS_CLIP, (OBS_SIZE,), np.float32)

        # --- episode, targets, metric ------------------------------------------------
        self.settle_length_mm = float(ep.get("settle_length_mm", 20.0))
        self.warmup_length_mm = float(ep.get("warmup_length_mm", 30.0))
        self.n_start_states = int(ep.get("start_states", 1))
        self.max_substeps = int(ep.get("max_substeps", 2000))
        self.metric_params = MetricParams.from_dict(sd.metric)
        tg = sd.target
        self.target_spacing_mm = float(tg["spacing_mm"])
        self.sampler = TargetSampler(
            self._make_family(tg), int(tg.get("eval_size", 16)), int(tg.get("eval_seed", 0))
        )
        self.fixed_target: Target | None = None
        if target_file is not None:
            self.fixed_target = load_target_file(target_file, self.target_spacing_mm)
        if target_index is not None:
            self._check_index(target_index, "target_index")
        self.target_index = target_index
        self._eval_cursor = 0

        self.sim: Simulation | None = None
        self.target: Target | None = None
        self._prepared_target: Target | None = None
        self._figure: Any = None
        self._diverged = False

    # ------------------------------------------------------------------ construction
    def _init_scene(self, accuracy: str, scene_overrides: dict[str, Any] | None) -> None:
        """The scene (spec overrides, accuracy preset, ``scene_overrides``; the flow set to
        the warm-up's) and the constants read from it: needle, densities, bath."""
        sd = self.spec_data
        ep = sd.episode
        self.warmup_q_outer = float(ep.get("warmup_q_outer_ml_min", 0.5))
        overrides: dict[str, Any] = dict(sd.scene.get("overrides", {}))
        overrides.update(accuracy_overrides(accuracy))
        overrides.update(scene_overrides or {})
        overrides.update(
            {
                "flow.schedule": [],
                "flow.q_outer_ml_min": self.warmup_q_outer,
                "flow.q_inner_ml_min": 0.0,
            }
        )
        self.scene_base = str(sd.scene.get("base", "gelation_coiling_22G"))
        try:
            probe = Simulation(self.scene_base, overrides)  # validates the scene
        except SceneError as exc:
            raise SceneConfigError(
                f"scene {self.scene_base!r} with the spec's overrides and scene_overrides = "
                f"{scene_overrides!r}: {exc}"
            ) from exc
        self.scene_overrides = overrides
        m = probe.model
        self.needle_area = m.needle_area  # m^2
        self.rho_gel = float(m.p.exit_density)
        self.phi_max = float(probe.scene.inclusions.max_inner_fraction)
        self.has_inclusions = bool(m.p.inclusions)
        self.needle_start_mm = np.array(m.needle[0, 1:4] / MM)
        self.needle_direction = np.array(m.needle[0, 4:7])
        grad = float(m.p.bath_density_gradient)  # kg/m^3 per m of depth
        rho_top = float(m.p.bath_density_top)
        depth_m = -float(m.p.floor_z)
        self.depth_mm = depth_m / MM
        self.bath_range = (rho_top, rho_top + grad * depth_m) if grad > 0 else None
        self.rho_bath_needle = rho_top + grad * max(-self.needle_start_mm[2] * MM, 0.0)

    def _check_index(self, index: Any, name: str) -> None:
        """An evaluation target index: an integer in 0..eval_size-1 (never wrapped)."""
        _check_index_type(index, name)
        n = self.sampler.eval_size
        if not 0 <= index < n:
            raise ConfigError(
                f"{name} = {index!r}; the evaluation set of {self.env_id} has {n} targets: "
                f"allowed 0..{n - 1}"
            )

    def _make_family(self, tg: dict[str, Any]) -> Any:
        family = tg.get("family")
        params = tg.get("params", {})
        h = float(tg["spacing_mm"])
        if family == "coil_schedule":
            return CoilScheduleFamily(params, float(tg["length_mm"]), h)
        if family == "sections":
            return SectionsFamily(params, h, self.rho_bath_needle)
        if family == "layers":
            if self.bath_range is None:
                raise ConfigError(f"{self.env_id}: the layers family needs a density-gradient bath")
            grad_mm = (self.bath_range[1] - self.bath_range[0]) / self.depth_mm
            return LayersFamily(params, float(tg["length_mm"]), h, self.bath_range[0], grad_mm)
        raise ConfigError(f"target.family = {family!r}; allowed: coil_schedule, sections, layers")

    def _start_state(self, index: int) -> bytes:
        """Pickled warm-up state number ``index`` (needle imperfection seed + index)."""
        seed = int(self.scene_overrides.get("seed", 0)) + index
        key_src = json.dumps(
            [self.scene_base, self.scene_overrides, seed, self.warmup_length_mm],
            sort_keys=True,
            default=str,
        )
        key = hashlib.sha1(key_src.encode()).hexdigest()
        if key not in _START_STATES:
            ov = dict(self.scene_overrides)
            ov["seed"] = seed
            v = self.warmup_q_outer * ML_MIN / self.needle_area  # m/s
            total_mm = self.warmup_length_mm + 200.0  # capacity estimate only (arrays grow)
            ov["duration_s"] = total_mm * MM / v
            sim = Simulation(self.scene_base, ov)
            sim.advance(self.warmup_length_mm * MM / v)
            _START_STATES[key] = pickle.dumps(sim)
        return _START_STATES[key]

    # ------------------------------------------------------------------ actions
    def action_to_controls(self, action: np.ndarray) -> dict[str, Any]:
        """Physical controls of an action (validated and clipped): flows in ml/min, offset,
        needle velocity in mm/s (3 components)."""
        a = np.asarray(action, dtype=np.float64)
        if a.shape != self.action_space.shape:
            raise ValueError(f"action shape {a.shape}; expected {self.action_space.shape}")
        values = a.tolist()
        if not all(map(math.isfinite, values)):
            raise ValueError(f"action {a!r} holds NaN or inf")
        values = [min(max(x, -1.0), 1.0) for x in values]
        index = self._action_index

        def affine(name: str, lo_hi: tuple[float, ...]) -> float:
            return lo_hi[0] + 0.5 * (values[index[name]] + 1.0) * (lo_hi[1] - lo_hi[0])

        qo = affine("q_outer", self.q_outer_range)
        qi = affine("q_inner", self.q_inner_range) if "q_inner" in index else 0.0
        qi = min(qi, self.phi_max / (1.0 - self.phi_max) * qo * (1.0 - 1e-9))
        off = affine("inclusion_offset", self.offset_range) if "inclusion_offset" in index else None
        vel = np.zeros(3)
        for axis in self.needle_axes:
            vel["xyz".index(axis)] = values[index[f"needle_v{axis}"]] * self.needle_speed_mm_s
        return {"q_outer_ml_min": qo, "q_inner_ml_min": qi, "inclusion_offset": off, "vel": vel}

    def controls_to_action(self, q_outer_ml_min: float, q_inner_ml_min: float = 0.0) -> np.ndarray:
        """The action that sets these flows (other components 0; offset mid-range)."""

        def inv(x: float, lo_hi: tuple[float, ...]) -> float:
            span = lo_hi[1] - lo_hi[0]
            return 0.0 if span <= 0 else 2.0 * (x - lo_hi[0]) / span - 1.0

        a = np.zeros(self.action_space.shape, np.float32)
        a[0] = inv(q_outer_ml_min, self.q_outer_range)
        if "q_inner" in self.action_names:
            a[self.action_names.index("q_inner")] = inv(q_inner_ml_min, self.q_inner_range)
        return np.clip(a, -1, 1)

    # ------------------------------------------------------------------ episode
    @property
    def episode_length_mm(self) -> float:
        """Printed length of a full episode: the target plus the settling length (mm)."""
        assert self.target is not None
        return self.target.length_mm + self.settle_length_mm

    @property
    def episode_steps(self) -> int:
        """Steps of a full episode (the environment terminates after this many)."""
        return int(math.ceil(self.episode_length_mm / self.control_length_mm - 1e-9))

    def _choose_target(self, options: dict[str, Any]) -> tuple[Target, int]:
        if "target" in options:
            t = options["target"]
            if not isinstance(t, Target):
                raise TypeError("options['target'] must be a bathprint.envs.targets.Target")
            return t, -1
        if self.fixed_target is not None:
            return self.fixed_target, -1
        if self.target_set == "eval":
            index = options.get("target_index", self.target_index)
            if index is not None:
                self._check_index(index, "options['target_index']")
            if index is None:
                index = self._eval_cursor % self.sampler.eval_size
                self._eval_cursor += 1
            return self.sampler.eval_target(int(index)), int(index)
        if options.get("target_index") is not None:
            raise ConfigError("target_index selects evaluation targets: use target_set='eval'")
        return self.sampler.train_target(self.np_random), -1

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        options = dict(options or {})
        if seed is not None:
            self._eval_cursor = 0
        start = int(self.np_random.integers(self.n_start_states))
        self.sim = pickle.loads(self._start_state(start))
        self.target, self._target_index = self._choose_target(options)
        self._start_index = start
        self._u0_mm = float(np.sum(self.sim.rest_lengths())) / MM
        self._controls = {
            "q_outer_ml_min": self.warmup_q_outer,
            "q_inner_ml_min": 0.0,
            "inclusion_offset": float(self.sim.model.p.inclusion_offset),
            "vel": np.zeros(3),
        }
        self._needle_mm = self.needle_start_mm.copy()
        self._needle_obs = [0.0, 0.0, 0.0]
        self._steps = 0
        self._diverged = False
        self._snapshot()
        self._metric = self._evaluate()
        obs = self._observe()
        self._last_obs = obs.copy()
        if self.render_mode == "human":
            self.render()
        return obs, self._info()

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self.sim is None:
            raise RuntimeError("call reset() before step()")
        c = self.action_to_controls(action)
        if self._diverged:  # stepping a diverged episode: nothing changes
            info = self._info()
            info["sim_error"] = self._error_message
            return self._last_obs.copy(), 0.0, False, True, info
        sim = self.sim
        old = self._controls
        qo, qi = c["q_outer_ml_min"], c["q_inner_ml_min"]
        t0 = sim.t
        q_new = (qo + qi) * ML_MIN
        ds = self.control_length_mm * MM * self.needle_area  # volume to extrude (m^3)
        if qo != old["q_outer_ml_min"] or qi != old["q_inner_ml_min"]:
            q_old = (old["q_outer_ml_min"] + old["q_inner_ml_min"]) * ML_MIN
            sim.set_flow(qo * ML_MIN, qi * ML_MIN)
            # the 1 us ramp extrudes (q_old + q_new)/2 * 1 us; the rest at q_new
            dt = RAMP_S + (ds - 0.5 * (q_old + q_new) * RAMP_S) / q_new
        else:
            dt = ds / q_new
        if c["inclusion_offset"] is not None and c["inclusion_offset"] != old["inclusion_offset"]:
            sim.set_inclusion_offset(c["inclusion_offset"])
        t1 = t0 + dt
        if self.needle_axes:
            target = np.clip(
                self._needle_mm + c["vel"] * dt, self.needle_box_mm[:, 0], self.needle_box_mm[:, 1]
            )
            c["vel"] = (target - self._needle_mm) / dt
            move_needle(sim, c["vel"] * MM, t1)
            self._needle_mm = target
            self._needle_obs = ((target - self.needle_start_mm) / OBS_NEEDLE_MM).tolist()
        self._controls = c
        self._steps += 1
        before = self._metric.value
        error: str | None = None
        try:
            sim.advance(t1, max_steps=self.max_substeps)
            if sim.t < t1 - 1e-12 * max(1.0, t1):
                raise SimulationError(
                    f"step budget used up ({self.max_substeps} integrator steps for one "
                    "environment step; episode.max_substeps)",
                    sim.t,
                    -1,
                )
            self._snapshot()
        except SimulationError as exc:
            error = str(exc)
            cause = exc.cause
        if error is not None:
            self._diverged = True
            self._error_message = error
            info = self._info()
            info["sim_error"] = error
            info["sim_error_cause"] = cause
            return self._last_obs.copy(), 0.0, False, True, info
        self._metric = self._evaluate()
        reward = before - self._metric.value
        terminated = self._printed_mm >= self._episode_length_mm - 1e-6
        obs = self._observe()
        self._last_obs = obs.copy()
        if self.render_mode == "human":
            self.render()
        return obs, float(reward), bool(terminated), False, self._info()

    # ------------------------------------------------------------------ state -> numbers
    def _snapshot(self) -> None:
        """Read the simulation once per step: positions (mm), material coordinate u (mm from
        the free end), densities, velocities (mm/s)."""
        sim = self.sim
        assert sim is not None
        x, v = sim.centerline(), sim.velocities()
        u, finite = read_state(x, v, sim.rest_lengths(), MM)  # x, v: m -> mm in place
        if not finite:
            raise SimulationError("non-finite state read by the environment", sim.t, -1)
        self._x, self._u, self._v = x, u, v
        self._rho = np.ascontiguousarray(sim.material()[:, L.MAT_DENSITY])
        self._printed_mm = float(u[-1] - self._u0_mm)

    def _prepare_target(self) -> None:
        """Per-target constants: the metric's, the observed target features, the key."""
        tgt = self.target
        assert tgt is not None
        aim = tgt.density_aim(self.rho_gel)
        self._target_features = np.ascontiguousarray(
            np.stack(
                [
                    tgt.curvature_1_mm * OBS_CURVATURE_MM,
                    tgt.torsion_1_mm * OBS_CURVATURE_MM,
                    (aim - OBS_DENSITY_REF_KG_M3) / OBS_DENSITY_SCALE_KG_M3,
                ],
                axis=1,
            ),
            np.float64,
        )
        self._prepared_metric: PreparedMetric = prepare(tgt, self.metric_params, self.bath_range)
        self._episode_length_mm = self.episode_length_mm
        self._target_key = tgt.key
        self._prepared_target = tgt

    def _interp(self, u_query: np.ndarray, values: np.ndarray) -> np.ndarray:
        """Rows of ``values`` (one per node) at material coordinates ``u_query`` (mm)."""
        out = np.empty((len(u_query), values.shape[1]))
        interp_rows(self._u, values, np.ascontiguousarray(u_query, np.float64), out)
        return out

    def _scored(self) -> int:
        """Number of target samples that are printed and settled."""
        assert self.target is not None
        s_f = self._printed_mm - self.settle_length_mm
        n = int(math.floor(s_f / self.target.spacing_mm + 1e-9)) + 1
        return max(0, min(n, self.target.n_samples))

    def printed_samples(self) -> PrintedSamples:
        """The scored part of the printed filament at the target's sample arclengths."""
        assert self.target is not None
        pts, dens = printed_at(
            self._u, self._x, self._rho, self._u0_mm, self.target.spacing_mm, self._scored()
        )
        return PrintedSamples(pts, dens)

    def _evaluate(self) -> MetricValue:
        if self._prepared_target is not self.target:
            self._prepare_target()
        p = self.printed_samples()
        return evaluate_prepared(self._prepared_metric, p.points_mm, p.density_kg_m3)

    def _observe(self) -> np.ndarray:
        tgt = self.target
        assert tgt is not None
        if self._prepared_target is not tgt:
            self._prepare_target()
        c = self._controls

        def to_unit(x: float, lo_hi: tuple[float, ...]) -> float:  # as controls_to_action
            span = lo_hi[1] - lo_hi[0]
            return min(max(0.0 if span <= 0 else 2.0 * (x - lo_hi[0]) / span - 1.0, -1.0), 1.0)

        off_span = self.offset_range[1] - self.offset_range[0]
        off = c["inclusion_offset"]
        controls = np.array(
            [
                to_unit(c["q_outer_ml_min"], self.q_outer_range),
                to_unit(c["q_inner_ml_min"], self.q_inner_range)
                if "q_inner" in self._action_index
                else -1.0,
                0.0
                if off is None or off_span <= 0
                else 2 * (off - self.offset_range[0]) / off_span - 1,
                *self._needle_obs,
            ]
        )
        m = self._metric
        progress = np.array(
            [
                self._printed_mm,
                tgt.spacing_mm,
                self._episode_length_mm,
                m.scored_fraction,
                m.value,
                self.metric_params.missing_error,
                self._scored(),
            ],
            np.float64,
        )
        return observe(
            self._x,
            self._v,
            self._u,
            self._rho,
            _OBS_KERNEL_LAYOUT,
            self._target_features,
            progress,
            controls,
            m.errors,
            OBS_CLIP,
        )

    def _info(self) -> dict[str, Any]:
        assert self.sim is not None and self.target is not None
        c, m = self._controls, self._metric
        return {
            "metric": m.value,
            "shape_rms_mm": m.shape_rms_mm,
            "curvature_rms_1_mm": m.curvature_rms_1_mm,
            "density_rms_kg_m3": m.density_rms_kg_m3,
            "scored_fraction": m.scored_fraction,
            "printed_length_mm": self._printed_mm,
            "episode_length_mm": self.episode_length_mm,
            "q_outer_ml_min": float(c["q_outer_ml_min"]),
            "q_inner_ml_min": float(c["q_inner_ml_min"]),
            "needle_mm": self._needle_mm.copy(),
            "sim_time_s": float(self.sim.t) if not self._diverged else float("nan"),
            "n_nodes": int(self._x.shape[0]),
            "target_key": self._target_key
            if self._prepared_target is self.target
            else self.target.key,
            "target_index": self._target_index,
            "start_state": self._start_index,
        }

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
