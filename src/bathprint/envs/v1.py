"""Version 1 of the bathprint environments: :class:`BathprintEnvV1`.

What differs from version 0 (:mod:`bathprint.envs.v0`), every difference one that changes
results (hence the new ids); :mod:`bathprint.envs.base` holds what both share:

- targets are printed by the environment itself from random smooth control sequences
  (:mod:`bathprint.envs.printed`): reachable by construction; three fixed, disjoint target
  sets ``train``, ``validation``, ``test``;
- target sample 0 lies ``episode.lead_in_mm`` of material after the first action's: nothing
  printed before the first action is scored (a segment split off the inlet is at most 1.5
  node spacings long, 1.2 mm at the coarsest preset, so the segments holding scored samples
  hold only material printed under the agent's control);
- a sample is recorded when it becomes scored (``settle_length_mm`` behind the tip: the
  shape has set, see below) and never changes after; the metric M is computed on the
  recorded samples, and the reward is the decrease of the sum of squared errors of the
  scored samples over the number of target samples, so that an episode's return is
  ``-M_final^2`` with no constant progress term;
- actions in physical terms: ``q_outer`` on a log scale (``control.q_outer_scale``), the
  ``q_inner`` action as the inner fraction phi (``control.q_inner_as = "fraction"``); the
  needle's velocity in the action by default where the targets need it (``control.needle``);
- an optional first-order lag of the oil flow (``control.inner_lag_s``);
- the observation holds only what varies in the environment, shows the target's density
  band (both bounds) and the scored error (not the missing samples'); it is built per
  environment (:attr:`BathprintEnvV1.obs_layout`);
- ``goal_conditioned=True``: a Dict observation (observation, achieved_goal,
  desired_goal) and :meth:`BathprintEnvV1.compute_reward`, for hindsight experience replay;
- ``info["is_success"]``: the print is finished and M <= ``success.metric_max``.

Recording at the settling length: measured on 80-220 mm episodes (constant, smooth-random
and moving-needle actions, draft), the windowed Kabsch distance between the filament as
recorded 20 mm behind the tip and as it is at the end is 0.05-0.16 mm on average (0.5 mm at
most) and the curvature differs by 0.001-0.012 1/mm RMS: small against the 3 mm length scale
of the metric. ``info["metric_final_shape"]`` at the end of an episode gives M of the final
filament, as version 0 computes it.
"""

from __future__ import annotations

import math
import os
from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces

from bathprint.envs._kernels import metric_errors, printed_at
from bathprint.envs._kernels_v1 import squared_sum
from bathprint.envs.base import (
    advance_to,
    check_accuracy,
    check_needle_velocity,
    check_render_mode,
    check_scene_overrides,
    is_index,
)
from bathprint.envs.goals import GoalLayout
from bathprint.envs.metric import MetricValue, prepare
from bathprint.envs.observation import (
    CURV_OFFSETS_MM,
    DENS_OFFSETS_MM,
    OBS_CLIP,
    OBS_CURVATURE_MM,
    OBS_DENSITY_REF_KG_M3,
    OBS_DENSITY_SCALE_KG_M3,
    OBS_LENGTH_MM,
    OBS_SPEED_MM_S,
    RECENT_SAMPLES,
    TARGET_OFFSETS_MM,
    TIP_OFFSETS_MM,
    VEL_OFFSETS_MM,
)
from bathprint.envs.printed import PrintedTargets
from bathprint.envs.printing import PrintingEnv
from bathprint.envs.spec import load_spec
from bathprint.envs.targets import FREE_DENSITY, Target, load_target_file
from bathprint.errors import ConfigError, SimulationError

TARGET_SETS = ("train", "validation", "test")
GOAL_POSITION_MM = 1000.0  # bound of the goals' positions (the bath is 125 mm deep)


class BathprintEnvV1(PrintingEnv):
    """The printed-target protocol of versions 1 and 2 (a version's spec says what it
    observes); see the module doc and the environments' docstrings."""

    version: ClassVar[int] = 1

    def __init__(
        self,
        render_mode: str | None = None,
        *,
        accuracy: str = "balanced",
        needle_velocity: bool | str | None = None,
        target_set: str = "train",
        target_index: int | None = None,
        target_file: str | None = None,
        goal_conditioned: bool = False,
        scene_overrides: dict[str, Any] | None = None,
        spec_overrides: dict[str, Any] | None = None,
        spec_file: str | None = None,
        _printer: bool = False,
    ) -> None:
        if not _printer:
            self._warn_if_superseded()
        self._check_kwargs(
            render_mode,
            accuracy,
            needle_velocity,
            target_set,
            target_index,
            target_file,
            goal_conditioned,
            scene_overrides,
        )
        if spec_file is not None and not isinstance(spec_file, str | os.PathLike):
            raise ConfigError(f"spec_file = {spec_file!r}; allowed: None or a path to a spec")
        self.render_mode = render_mode
        self.accuracy = accuracy
        self.target_set = target_set
        self.goal_conditioned = bool(goal_conditioned)
        self.spec_file = spec_file
        self.spec_overrides_given = spec_overrides
        #: what another instance with the same task needs (planners make one)
        self.init_kwargs: dict[str, Any] = {
            "accuracy": accuracy,
            "needle_velocity": needle_velocity,
            "scene_overrides": scene_overrides,
            "spec_overrides": spec_overrides,
            "spec_file": spec_file,
        }
        self.spec_data = load_spec(None if spec_file else self.env_id, spec_file, spec_overrides)
        sd = self.spec_data
        if sd.version < 1:
            raise ConfigError(
                f"spec_file = {spec_file!r} is a version-{sd.version} spec; {self.env_id} "
                "needs version >= 1"
            )
        self._init_scene(accuracy, scene_overrides)
        self._init_controls(needle_velocity)
        self._init_episode()
        self._init_targets(target_file, target_index, _printer)
        self._init_observation()

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
        needle_velocity: Any,
        target_set: Any,
        target_index: Any,
        target_file: Any,
        goal_conditioned: Any,
        scene_overrides: Any,
    ) -> None:
        check_render_mode(render_mode)
        check_accuracy(accuracy)
        if isinstance(target_set, str) and target_set == "eval":
            raise ConfigError(
                "target_set = 'eval' is version 0's held-out set; version 1 has 'train', "
                "'validation' (model selection, early stopping) and 'test' (reported numbers)"
            )
        if not isinstance(target_set, str) or target_set not in TARGET_SETS:
            raise ConfigError(
                f"target_set = {target_set!r}; allowed: " + ", ".join(map(repr, TARGET_SETS))
            )
        check_needle_velocity(needle_velocity)
        if not isinstance(goal_conditioned, bool):
            raise ConfigError(f"goal_conditioned = {goal_conditioned!r}; allowed: True, False")
        check_scene_overrides(scene_overrides)
        if target_file is not None and not isinstance(target_file, str):
            raise ConfigError(f"target_file = {target_file!r}; allowed: None or a path")
        if target_index is not None:
            if not is_index(target_index):
                raise ConfigError(
                    f"target_index = {target_index!r}; allowed: an integer (a validation or "
                    "test target)"
                )
            if target_set not in ("validation", "test"):
                raise ConfigError(
                    f"target_index = {target_index!r} selects a fixed target: use "
                    "target_set='validation' or 'test'"
                )
            if target_file is not None:
                raise ConfigError(
                    f"target_index = {target_index!r} and target_file = {target_file!r}: a "
                    "target file is the only target; give one of them"
                )

    def _check_index(self, index: Any, name: str) -> None:
        """A target index of the fixed set in use: an integer in 0..size-1 (never wrapped)."""
        if not is_index(index):
            raise ConfigError(f"{name} = {index!r}; allowed: an integer")
        if self.target_set not in ("validation", "test") or self.printed is None:
            raise ConfigError(
                f"{name} = {index!r} selects a fixed target: use target_set='validation' or 'test'"
            )
        n = self.printed.sizes[self.target_set]
        if not 0 <= index < n:
            raise ConfigError(
                f"{name} = {index!r}; the {self.target_set} set of {self.env_id} has {n} "
                f"targets: allowed 0..{n - 1}"
            )

    def _init_targets(
        self, target_file: str | None, target_index: int | None, printer: bool
    ) -> None:
        """The printed target family (none in a printer, which is given its targets), or
        the file's target; the fixed set's index."""
        sd = self.spec_data
        tg = sd.target
        self.target_spacing_mm = float(tg["spacing_mm"])
        self.target_length_mm = float(tg["length_mm"])
        self.n_target_samples = int(round(self.target_length_mm / self.target_spacing_mm)) + 1
        if tg.get("family") != "printed":
            raise ConfigError(
                f"{sd.path}: target.family = {tg.get('family')!r}; version 1 has 'printed'"
            )
        self.printed: PrintedTargets | None = None if printer else PrintedTargets(self)
        self.fixed_target: Target | None = None
        if target_file is not None:
            try:
                self.fixed_target = load_target_file(target_file, self.target_spacing_mm)
            except (ValueError, FileNotFoundError) as exc:
                raise ConfigError(f"target_file = {target_file!r}: {exc}") from None
            if self.goal_conditioned and self.fixed_target.n_samples > self.n_target_samples:
                raise ConfigError(
                    f"target_file = {target_file!r}: {self.fixed_target.n_samples} samples; "
                    f"goal_conditioned=True allows at most {self.n_target_samples} "
                    f"({self.target_length_mm:g} mm)"
                )
        if target_index is not None:
            self._check_index(target_index, "target_index")
        self.target_index = target_index
        self._eval_cursor = 0

    def _init_observation(self) -> None:
        """The observation layout of this environment (only what varies in it)."""
        mp = self.metric_params
        ob = self.spec_data.observation
        self.obs_density_ref = float(ob.get("density_ref_kg_m3", OBS_DENSITY_REF_KG_M3))
        self.obs_density_scale = float(ob.get("density_scale_kg_m3", OBS_DENSITY_SCALE_KG_M3))
        self.scores_shape = mp.w_shape > 0 or mp.w_curvature > 0
        self.scores_density = mp.w_density > 0
        self.observes_density = self.scores_density or "q_inner" in self.action_names
        self.goals = GoalLayout(
            self.n_target_samples,
            self.scores_shape,
            self.scores_density,
            mp,
            self.target_spacing_mm,
            self.bath_range,
        )
        feats = (["curvature", "torsion"] if self.scores_shape else []) + (
            ["density_lo", "density_hi"] if self.scores_density else []
        )
        self.target_feature_names: list[str] = feats
        layout: list[tuple[str, int]] = [
            ("tip_relative_positions", 3 * len(TIP_OFFSETS_MM)),
            ("velocities", 3 * len(VEL_OFFSETS_MM)),
            ("printed_curvature", len(CURV_OFFSETS_MM)),
        ]
        if self.observes_density:
            layout.append(("printed_density", len(DENS_OFFSETS_MM)))
        if not self.goal_conditioned:
            layout.append(("target", len(feats) * len(TARGET_OFFSETS_MM)))
        layout.append(("controls", len(self.action_names)))
        if self.inner_lag_s > 0:
            layout.append(("inner_fraction_now", 1))
        if self.needle_axes:
            layout.append(("needle_position", len(self.needle_axes)))
        layout.append(("progress", 2 if self.goal_conditioned else 4))
        # the target's own positions near the needle's sample, relative to the needle
        # (observation.target_positions_mm; the goal form holds the whole target already)
        offsets = [] if self.goal_conditioned else ob.get("target_positions_mm", [])
        self._obs_tpos_off = np.asarray(offsets, np.float64)
        if len(offsets):
            layout.append(("target_positions", 3 * len(offsets)))
        self.obs_layout: tuple[tuple[str, int], ...] = tuple(layout)
        size = sum(n for _, n in layout)
        self._obs_dens_off = np.array(DENS_OFFSETS_MM) if self.observes_density else np.zeros(0)
        self._obs_scales = np.array(
            [
                OBS_LENGTH_MM,
                OBS_SPEED_MM_S,
                OBS_CURVATURE_MM,
                self.obs_density_ref,
                self.obs_density_scale,
            ]
        )
        self._obs_tgt_off = np.array(TARGET_OFFSETS_MM)
        flat = spaces.Box(-OBS_CLIP, OBS_CLIP, (size,), np.float32)
        if not self.goal_conditioned:
            self.observation_space = flat
            return
        n = self.n_target_samples
        self.goal_size = (3 * n if self.scores_shape else 0) + (2 * n if self.scores_density else 0)
        self.goal_size += 2
        low, high = (
            self.goals.vector(np.full((n, 3), -GOAL_POSITION_MM), np.zeros(n), np.zeros(n), 0, 0),
            self.goals.vector(
                np.full((n, 3), GOAL_POSITION_MM),
                np.full(n, FREE_DENSITY[1]),
                np.full(n, FREE_DENSITY[1]),
                n,
                n,
            ),
        )
        goal = spaces.Box(low, high, dtype=np.float64)
        self.compute_reward = self.goal_reward  # the goal-environment interface
        self.observation_space = spaces.Dict(
            {"observation": flat, "achieved_goal": goal, "desired_goal": goal}
        )

    # ------------------------------------------------------------------ actions
    def actions_for(self, target: Target) -> np.ndarray:
        """The actions that printed ``target`` in this environment's action layout (needle
        components this layout adds stay 0)."""
        if target.actions is None:
            raise ValueError(f"target {target.name!r} was not printed: it has no actions")
        src = {name: k for k, name in enumerate(self.default_action_names)}
        out = np.zeros((len(target.actions), len(self.action_names)), np.float32)
        for k, name in enumerate(self.action_names):
            if name in src:
                out[:, k] = target.actions[:, src[name]]
        missing = [n for n in self.default_action_names if n not in self._action_index]
        if missing and np.any(target.actions[:, [src[n] for n in missing]] != 0):
            raise ValueError(
                f"target {target.name!r} was printed with {', '.join(missing)}, which this "
                "environment's actions lack (needle_velocity)"
            )
        return out

    # ------------------------------------------------------------------ episode
    def blank_target(self) -> Target:
        """A straight target of the spec's length (for printing targets)."""
        n, h = self.n_target_samples, self.target_spacing_mm
        pts = np.zeros((n, 3))
        pts[:, 2] = -np.arange(n) * h
        zeros = np.zeros(n)
        return Target(
            name="blank",
            params={"family": "blank", "length_mm": self.target_length_mm},
            spacing_mm=h,
            points_mm=pts,
            curvature_1_mm=zeros,
            torsion_1_mm=zeros.copy(),
            density_lo_kg_m3=np.full(n, FREE_DENSITY[0]),
            density_hi_kg_m3=np.full(n, FREE_DENSITY[1]),
        )

    def fixed_set_target(self, target_set: str, index: int) -> Target:
        """Target ``index`` of the validation or test set."""
        assert self.printed is not None
        seeds = self.printed.seeds(target_set)
        if not 0 <= index < len(seeds):
            raise IndexError(
                f"target_index = {index!r}; the {target_set} set has {len(seeds)} targets"
            )
        return self.printed.get(seeds[index])

    def _choose_target(self, options: dict[str, Any]) -> tuple[Target, int]:
        if "target" in options:
            t = options["target"]
            if not isinstance(t, Target):
                raise TypeError("options['target'] must be a bathprint.envs.targets.Target")
            return t, -1
        if self.fixed_target is not None:
            return self.fixed_target, -1
        if self.printed is None:
            raise RuntimeError("this environment prints targets: reset it with a target")
        if self.target_set in ("validation", "test"):
            index = options.get("target_index", self.target_index)
            if index is not None:
                self._check_index(index, "options['target_index']")
            else:
                index = self._eval_cursor % self.printed.sizes[self.target_set]
                self._eval_cursor += 1
            return self.fixed_set_target(self.target_set, int(index)), int(index)
        if options.get("target_index") is not None:
            raise ConfigError(
                "options['target_index'] selects a fixed target: use target_set='validation' "
                "or 'test'"
            )
        return self.printed.get(self.printed.train_seed(self.np_random)), -1

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        super().reset(seed=seed)
        options = dict(options or {})
        if seed is not None:
            self._eval_cursor = 0
        drawn = int(self.np_random.integers(self.n_start_states))
        self.target, self._target_index = self._choose_target(options)
        if "target" in options:
            self._target_source = "option"
        elif self.fixed_target is not None:
            self._target_source = "file"
        else:
            self._target_source = self.target_set
        start = self.target.params.get("start_state", drawn)
        if "start_state" in options:
            start = options["start_state"]
            if not (is_index(start) and 0 <= start < self.n_start_states):
                raise ConfigError(
                    f"options['start_state'] = {start!r}; allowed 0..{self.n_start_states - 1}"
                )
        self._begin_episode(int(start))
        self._sse = 0.0
        self._snapshot()
        if self._prepared_target is not self.target:
            self._prepare_target()
        self._metric = self._evaluate()
        obs = self._observe()
        self._last_obs = obs
        if self.render_mode == "human":
            self.render()
        return self._obs_out(obs), self._info()

    def step(self, action: np.ndarray) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        if self.sim is None:
            raise RuntimeError("call reset() before step()")
        c = self.action_to_controls(action)
        if self._diverged:  # stepping a diverged episode: nothing changes
            info = self._info()
            info["sim_error"] = self._error_message
            return self._obs_out(self._last_obs), 0.0, False, True, info
        t_end = self._apply_controls(c)
        self._steps += 1
        try:
            advance_to(self.sim, t_end, self.max_substeps)
            self._snapshot()
        except SimulationError as exc:
            return self._diverge(exc)
        sse_before = self._sse
        self._record()
        self._metric = self._evaluate()
        reward = (sse_before - self._sse) / self.target.n_samples
        terminated = self._printed_mm >= self._episode_length_mm - 1e-6
        obs = self._observe()
        self._last_obs = obs
        if self.render_mode == "human":
            self.render()
        info = self._info()
        if terminated:
            info["metric_final_shape"] = self._final_shape_metric()
            info["is_success"] = bool(self._metric.value <= self.success_metric_max)
        return self._obs_out(obs), float(reward), bool(terminated), False, info

    def _diverge(self, exc: SimulationError) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """End the episode where the simulation diverged: truncated, the last finite
        observation; the unscored samples count as missing, so the return is -M^2 of the
        diverged print."""
        self._diverged = True
        self._error_message = str(exc)
        n = self.target.n_samples
        miss2 = self.metric_params.missing_error**2
        reward = -(n - self._n_scored) * miss2 / n
        info = self._info()
        info["sim_error"] = self._error_message
        info["sim_error_cause"] = exc.cause
        return self._obs_out(self._last_obs), float(reward), False, True, info

    # ------------------------------------------------------------------ scoring
    def _prepare_target(self) -> None:
        tgt = self.target
        assert tgt is not None
        cols = []
        if self.scores_shape:
            cols += [tgt.curvature_1_mm * OBS_CURVATURE_MM, tgt.torsion_1_mm * OBS_CURVATURE_MM]
        if self.scores_density:
            ref, scale = self.obs_density_ref, self.obs_density_scale
            cols += [
                np.clip((tgt.density_lo_kg_m3 - ref) / scale, -OBS_CLIP, OBS_CLIP),
                np.clip((tgt.density_hi_kg_m3 - ref) / scale, -OBS_CLIP, OBS_CLIP),
            ]
        n = tgt.n_samples
        tfeat = np.stack(cols, axis=1) if cols else np.zeros((n, 0))
        self._target_features = np.ascontiguousarray(
            tfeat if not self.goal_conditioned else np.zeros((n, 0)), np.float64
        )
        self._prepared_metric = prepare(tgt, self.metric_params, self.bath_range)
        self._episode_length_mm = self.episode_length_mm
        self._target_key = tgt.key
        self._prepared_target = tgt
        if self.goal_conditioned:
            self._desired_goal = self.goals.vector(
                tgt.points_mm, tgt.density_lo_kg_m3, tgt.density_hi_kg_m3, n, n
            )

    def _evaluate(self) -> MetricValue:
        j = self._n_scored
        args = self._prepared_metric.args
        errors, value, shape, curv, dens = metric_errors(
            self._rec_pts[:j], self._rec_rho[:j], *args
        )
        self._sse = squared_sum(errors, j)
        self._errors = errors
        n = self._prepared_metric.n_samples
        return MetricValue(value, shape, curv, dens, j / n, errors)

    def _final_shape_metric(self) -> float:
        """M of the filament as it is now, sampled at the target's arclengths (version 0's
        way: positions now, not as recorded)."""
        n = self.target.n_samples
        pts, rho = printed_at(
            self._u, self._x, self._rho, self._origin_mm, self.target.spacing_mm, n
        )
        return float(metric_errors(pts, rho, *self._prepared_metric.args)[1])

    # ------------------------------------------------------------------ observation
    def _observe(self) -> np.ndarray:
        tgt = self.target
        assert tgt is not None
        extra = self._control_extras()
        n, j = tgt.n_samples, self._n_scored
        miss = self.metric_params.missing_error
        extra += [self._printed_mm / self._episode_length_mm, j / n]
        if not self.goal_conditioned:
            lo = max(0, j - RECENT_SAMPLES)
            recent = squared_sum(self._errors[lo:j], j - lo) if j > lo else 0.0
            extra += [
                math.sqrt(self._sse / j) / miss if j else 0.0,
                math.sqrt(recent / (j - lo)) / miss if j > lo else 0.0,
            ]
        if self._obs_tpos_off.size:
            extra += self._target_positions()
        return self._observation(extra)

    # ------------------------------------------------------------------ goals
    def _achieved_goal(self) -> np.ndarray:
        j = self._n_scored
        return self.goals.vector(
            self._rec_pts[:j], self._rec_rho[:j], self._rec_rho[:j], j, self._n_scored_prev
        )

    def goal_reward(
        self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any = None
    ) -> np.ndarray | float:
        """The reward of reaching ``achieved_goal`` (the step's) for ``desired_goal``: the
        decrease of the sum of squared errors of the scored samples (from the achieved
        goal's previous count to its count) over the desired goal's number of samples.
        Equal to the step reward (diverged steps aside); batches of goals give an array
        (HER). ``info`` is not used. With ``goal_conditioned=True`` this is also the
        environment's ``compute_reward`` (only then: checkers take an environment with
        ``compute_reward`` for a goal environment)."""
        if not self.goal_conditioned:
            raise RuntimeError("goal rewards need goal_conditioned=True")
        ag = np.asarray(achieved_goal, np.float64)
        dg = np.asarray(desired_goal, np.float64)
        single = ag.ndim == 1
        out = self.goals.rewards(
            np.ascontiguousarray(np.atleast_2d(ag)), np.ascontiguousarray(np.atleast_2d(dg))
        )
        return float(out[0]) if single else out

    def _goal_reward_one_by_one(self, achieved: np.ndarray, desired: np.ndarray) -> np.ndarray:
        """:meth:`goal_reward` of rows of goals, sample by sample in Python: the reference
        the compiled batch matches bit for bit (tests, experiments/hindsight/hindsight.py)."""
        return self.goals.rewards_one_by_one(achieved, desired)

    def _obs_out(self, obs: np.ndarray) -> Any:
        if not self.goal_conditioned:
            return obs.copy()
        return {
            "observation": obs.copy(),
            "achieved_goal": self._achieved_goal(),
            "desired_goal": self._desired_goal.copy(),
        }

    # ------------------------------------------------------------------ info, state
    def _info(self) -> dict[str, Any]:
        assert self.sim is not None and self.target is not None
        c, m = self._controls, self._metric
        n = self.target.n_samples
        return {
            "metric": m.value,
            "shape_rms_mm": m.shape_rms_mm,
            "curvature_rms_1_mm": m.curvature_rms_1_mm,
            "density_rms_kg_m3": m.density_rms_kg_m3,
            "scored_fraction": m.scored_fraction,
            "scored_squared_error": self._sse / n,
            "is_success": False,
            "printed_length_mm": self._printed_mm,
            "episode_length_mm": self._episode_length_mm,
            "q_outer_ml_min": float(c["q_outer_ml_min"]),
            "q_inner_ml_min": float(c["q_inner_ml_min"]),
            "inner_fraction": float(c["inner_fraction"]),
            "needle_mm": self._needle_mm.copy(),
            "sim_time_s": float(self.sim.t) if not self._diverged else float("nan"),
            "n_nodes": int(self._x.shape[0]),
            "target_key": self._target_key,
            "target_set": self._target_source,
            "target_index": self._target_index,
            "start_state": self._start_index,
        }

    def get_state(self) -> dict[str, Any]:
        """Everything the episode's future depends on (the simulation pickled), for
        :meth:`set_state` on this or another instance with the same settings: planners
        branch from it."""
        return self._printing_state()

    def set_state(self, state: dict[str, Any]) -> None:
        """Continue from a :meth:`get_state` snapshot."""
        self._restore_printing_state(state)
        if self._prepared_target is not self.target:
            self._prepare_target()
        if not self._diverged:
            self._snapshot()
        self._metric = self._evaluate()
