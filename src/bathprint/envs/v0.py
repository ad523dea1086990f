"""Version 0 of the bathprint environments: :class:`BathprintEnvV0`.

Targets are drawn from analytic families (coil schedules, sections of helices, straight
pieces and arcs, layers) and scored on the filament as it is at each step; the reward is
the decrease of the metric M (:mod:`bathprint.envs.metric`), so an episode's return is
``missing_error - M_final``. One observation layout
(:data:`bathprint.envs.observation.OBS_LAYOUT`, 94 entries) serves the three environments;
the fixed held-out set is ``target_set="eval"``. Superseded by version 1
(:mod:`bathprint.envs.v1`); registered so that results made with it reproduce.
"""

from __future__ import annotations

import math
import pickle
from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces

from bathprint.envs._kernels import observe, printed_at
from bathprint.envs.base import (
    MM,
    BathprintEnvBase,
    advance_to,
    check_accuracy,
    check_path,
    check_render_mode,
    check_scene_overrides,
    is_index,
    move_needle_within,
    set_flows,
)
from bathprint.envs.metric import (
    MetricParams,
    MetricValue,
    PreparedMetric,
    PrintedSamples,
    evaluate_prepared,
    prepare,
)
from bathprint.envs.observation import (
    KERNEL_LAYOUT_V0,
    OBS_CLIP,
    OBS_CURVATURE_MM,
    OBS_DENSITY_REF_KG_M3,
    OBS_DENSITY_SCALE_KG_M3,
    OBS_NEEDLE_MM,
    OBS_SIZE,
)
from bathprint.envs.spec import EnvSpecData, load_spec
from bathprint.envs.targets import (
    CoilScheduleFamily,
    LayersFamily,
    SectionsFamily,
    Target,
    TargetSampler,
    load_target_file,
)
from bathprint.errors import ConfigError, SimulationError

__all__ = ["BathprintEnvV0"]


def _check_index_type(index: Any, name: str = "target_index") -> None:
    if not is_index(index):
        raise ConfigError(f"{name} = {index!r}; allowed: an integer (an evaluation target)")


class BathprintEnvV0(BathprintEnvBase):
    """Version 0's machinery; see the module doc and the environments' docstrings."""

    version: ClassVar[int] = 0

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
        self._warn_if_superseded()
        self._check_kwargs(
            render_mode, accuracy, target_set, target_index, target_file, scene_overrides,
            spec_file,
        )  # fmt: skip
        self.render_mode = render_mode
        self.accuracy = accuracy
        self.target_set = target_set
        self.spec_data: EnvSpecData = load_spec(
            None if spec_file else self.env_id, spec_file, spec_overrides
        )
        self._init_scene(accuracy, scene_overrides)
        self._init_controls(needle_velocity)
        self._init_episode()
        self._init_targets(target_file, target_index)
        self.observes_density = True
        self.sim = None
        self.target: Target | None = None
        self._prepared_target: Target | None = None
        self._figure: Any = None
        self._diverged = False

    # ------------------------------------------------------------------ construction
    @staticmethod
    def _check_kwargs(
        render_mode: Any,
        accuracy: Any,
        target_set: Any,
        target_index: Any,
        target_file: Any,
        scene_overrides: Any,
        spec_file: Any,
    ) -> None:
        """Refuse bad arguments before any work (ConfigError naming the argument)."""
        check_render_mode(render_mode)
        if target_set not in ("train", "eval"):
            raise ConfigError(f"target_set = {target_set!r}; allowed: 'train', 'eval'")
        check_accuracy(accuracy)
        check_scene_overrides(scene_overrides)
        check_path(target_file, "target_file", "a path to a CSV or NPY polyline")
        check_path(spec_file, "spec_file", "a path to a spec TOML")
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

    def _init_controls(self, needle_velocity: bool | str) -> None:
        """The action's components and ranges (the spec's ``[control]``), the spaces."""
        ctl = self.spec_data.control
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

    def _init_episode(self) -> None:
        """Lengths and budgets of an episode and the metric (the spec's ``[episode]``,
        ``[metric]``)."""
        ep = self.spec_data.episode
        self.settle_length_mm = float(ep.get("settle_length_mm", 20.0))
        self.warmup_length_mm = float(ep.get("warmup_length_mm", 30.0))
        self.n_start_states = int(ep.get("start_states", 1))
        self.max_substeps = int(ep.get("max_substeps", 2000))
        self.metric_params = MetricParams.from_dict(self.spec_data.metric)

    def _init_targets(self, target_file: str | None, target_index: int | None) -> None:
        """The target family and its evaluation set, or the file's target."""
        tg = self.spec_data.target
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
        t_end = self._apply_controls(c)
        self._steps += 1
        before = self._metric.value
        try:
            advance_to(self.sim, t_end, self.max_substeps)
            self._snapshot()
        except SimulationError as exc:
            return self._diverge(exc)
        self._metric = self._evaluate()
        reward = before - self._metric.value
        terminated = self._printed_mm >= self._episode_length_mm - 1e-6
        obs = self._observe()
        self._last_obs = obs.copy()
        if self.render_mode == "human":
            self.render()
        return obs, float(reward), bool(terminated), False, self._info()

    def _apply_controls(self, c: dict[str, Any]) -> float:
        """Set the simulation to the step's controls ``c`` (flows, offset, needle velocity,
        clipped to the box: ``c["vel"]`` is updated) and return the time (s) it ends at."""
        sim = self.sim
        assert sim is not None
        old = self._controls
        t0 = sim.t
        ds = self.control_length_mm * MM * self.needle_area  # volume to extrude (m^3)
        dt = set_flows(
            sim,
            c["q_outer_ml_min"],
            c["q_inner_ml_min"],
            old["q_outer_ml_min"],
            old["q_inner_ml_min"],
            ds,
        )
        if c["inclusion_offset"] is not None and c["inclusion_offset"] != old["inclusion_offset"]:
            sim.set_inclusion_offset(c["inclusion_offset"])
        t1 = t0 + dt
        if self.needle_axes:
            self._needle_mm, c["vel"] = move_needle_within(
                sim, self._needle_mm, c["vel"], dt, self.needle_box_mm, t1
            )
            self._needle_obs = ((self._needle_mm - self.needle_start_mm) / OBS_NEEDLE_MM).tolist()
        self._controls = c
        return t1

    def _diverge(
        self, exc: SimulationError
    ) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """End the episode where the simulation diverged: truncated, reward 0, the last
        finite observation; ``info`` says why."""
        self._diverged = True
        self._error_message = str(exc)
        info = self._info()
        info["sim_error"] = self._error_message
        info["sim_error_cause"] = exc.cause
        return self._last_obs.copy(), 0.0, False, True, info

    # ------------------------------------------------------------------ state -> numbers
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
            KERNEL_LAYOUT_V0,
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
