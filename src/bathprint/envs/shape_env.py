"""The shape environments (spec version 3): :class:`ShapeEnv`, write a named shape of one
family of :mod:`bathprint.envs.shapes`, scored by the whole-shape error in millimetres.

What differs from version 1 (:mod:`bathprint.envs.v1`; :mod:`bathprint.envs.printing` holds
the controls and the recording both use):

- targets are shapes of the spec's family (``target.shape_family``): drawn from the family's
  generator for training (:class:`~bathprint.envs.shapes.ShapeGenerator`, never a held-out
  shape or kind), the named ``validation``, ``test`` and ``ood_test`` shapes for evaluation;
- a floor shape is placed to start under the needle and turned about the vertical to keep
  the largest margin inside the needle's box (its rigid motions leave it the same shape);
- ``info["metric"]`` is the whole-shape RMS error (mm) of the recorded samples against the
  target after the family's best rigid motion (:func:`~bathprint.envs.shape_metric.
  shape_error` at the end; on the scored prefix during the episode), ``info["max_mm"]`` the
  largest distance, ``info["is_success"]`` the family's threshold on both; the local metric
  of version 1 is ``info["local_metric"]`` at the end;
- the reward is potential-based, so that the return is a function of the reported error:
  Phi = -(1/N) sum_i min(e_i^2, m^2) / L^2, e_i the aligned distance of scored sample i
  (m = ``reward.missing_error_mm`` for the others), L = ``reward.length_scale_mm``; at the
  end Phi = -min(rms^2, m^2) / L^2 with the reported rms; a diverged episode ends at
  Phi = -2 m^2 / L^2. The return is (m^2 - min(rms^2, m^2)) / L^2: decreasing in the
  reported error until it reaches m, and below every finished print's when the simulation
  diverges.

Potential-based shaping leaves the optimal policy unchanged (Ng, Harada & Russell 1999,
ICML, "Policy invariance under reward transformations").
"""

from __future__ import annotations

import dataclasses
import math
import os
from typing import Any, ClassVar

import numpy as np
from gymnasium import spaces

from bathprint.envs._kernels import metric_errors
from bathprint.envs._kernels_shape import MOTIONS, prefix_error_sums
from bathprint.envs.base import (
    advance_to,
    check_accuracy,
    check_needle_velocity,
    check_render_mode,
    check_scene_overrides,
    is_index,
)
from bathprint.envs.metric import prepare
from bathprint.envs.observation import (
    CURV_OFFSETS_MM,
    DENS_OFFSETS_MM,
    OBS_CLIP,
    OBS_CURVATURE_MM,
    OBS_DENSITY_REF_KG_M3,
    OBS_DENSITY_SCALE_KG_M3,
    OBS_LENGTH_MM,
    OBS_SPEED_MM_S,
    TARGET_OFFSETS_MM,
    TIP_OFFSETS_MM,
    VEL_OFFSETS_MM,
)
from bathprint.envs.printing import PrintingEnv
from bathprint.envs.shape_metric import THRESHOLDS, shape_error
from bathprint.envs.spec import load_spec
from bathprint.envs.targets import Target
from bathprint.errors import ConfigError, SimulationError

SHAPE_SETS = ("train", "validation", "test", "ood_test")


class ShapeEnv(PrintingEnv):
    """Write a shape of the spec's family (module doc; each registered id's docstring says
    its family, actions and observation)."""

    version: ClassVar[int] = 3

    def __init__(
        self,
        render_mode: str | None = None,
        *,
        accuracy: str = "balanced",
        needle_velocity: bool | str | None = None,
        target_set: str = "train",
        target_index: int | None = None,
        target_file: str | None = None,
        scene_overrides: dict[str, Any] | None = None,
        spec_overrides: dict[str, Any] | None = None,
        spec_file: str | None = None,
    ) -> None:
        self._warn_if_superseded()
        check_render_mode(render_mode)
        check_accuracy(accuracy)
        check_scene_overrides(scene_overrides)
        if not isinstance(target_set, str) or target_set not in SHAPE_SETS:
            raise ConfigError(
                f"target_set = {target_set!r}; allowed: " + ", ".join(map(repr, SHAPE_SETS))
            )
        check_needle_velocity(needle_velocity)
        if target_file is not None and not isinstance(target_file, str | os.PathLike):
            raise ConfigError(f"target_file = {target_file!r}; allowed: None or a path")
        if spec_file is not None and not isinstance(spec_file, str | os.PathLike):
            raise ConfigError(f"spec_file = {spec_file!r}; allowed: None or a path to a spec")
        self.render_mode = render_mode
        self.accuracy = accuracy
        self.target_set = target_set
        self.goal_conditioned = False
        self.init_kwargs: dict[str, Any] = {
            "accuracy": accuracy,
            "needle_velocity": needle_velocity,
            "scene_overrides": scene_overrides,
            "spec_overrides": spec_overrides,
            "spec_file": spec_file,
        }
        self.spec_data = load_spec(None if spec_file else self.env_id, spec_file, spec_overrides)
        sd = self.spec_data
        if sd.version != 3 or sd.target.get("family") != "shapes":
            raise ConfigError(
                f"{sd.path}: a shape environment needs version = 3 and target.family = "
                f"'shapes'; got version {sd.version}, family {sd.target.get('family')!r}"
            )
        self.family = str(sd.target["shape_family"])
        self.threshold = THRESHOLDS[self.family]
        rw = sd.reward
        self.length_scale_mm = float(rw.get("length_scale_mm", self.threshold.rms_max_mm))
        self.missing_error_mm = float(rw.get("missing_error_mm", 2 * self.threshold.rms_max_mm))
        self._init_scene(accuracy, scene_overrides)
        self._init_controls(needle_velocity)
        self._init_episode()
        self.success_metric_max = self.threshold.rms_max_mm
        self.target_spacing_mm = float(sd.target["spacing_mm"])
        self.target_length_mm = float(sd.target.get("length_mm", 80.0))
        self.printed = None
        self._init_shapes(target_file, target_index)
        self._init_observation()
        self.sim = None
        self.target: Target | None = None
        self._figure: Any = None
        self._diverged = False

    # ------------------------------------------------------------------ targets
    def _init_shapes(self, target_file: str | None, target_index: int | None) -> None:
        """The family's generator and named sets (as targets of this environment); a file's
        shape as the only target."""
        from bathprint.envs.shape_files import load_shape_file
        from bathprint.envs.shapes import ShapeGenerator, family_shapes, index

        self.generator = ShapeGenerator(self.family)
        self._train_targets: dict[str, Target] = {}
        meta = {(r["set"], r["name"]): r for r in index() if r["family"] == self.family}
        self.named: dict[str, list[Target]] = {}
        for st in SHAPE_SETS[1:]:
            self.named[st] = [
                self.shape_target(pts, name, meta[(st, name)]["writable"])
                for name, pts in family_shapes(self.family, st)
            ]
        self.set_sizes = {st: len(v) for st, v in self.named.items()}
        self.fixed_target: Target | None = None
        if target_file is not None:
            pts = load_shape_file(target_file, self, self.family)
            self.fixed_target = self.shape_target(pts, os.path.basename(str(target_file)), True)
        if target_index is not None:
            self._check_index(target_index, "target_index")
        self.target_index = target_index
        self._eval_cursor = 0

    def shape_target(self, points: np.ndarray, name: str, writable: bool = True) -> Target:
        """The target of a shape: its reference curve every ``target.spacing_mm``, placed
        in the bath for the floor family (module doc)."""
        from bathprint.envs.shape_files import shape_target
        from bathprint.envs.shape_geometry import place_in_box

        pts = np.asarray(points, float)
        if self.family == "floor":
            placed = np.empty_like(pts)
            placed[:, :2] = place_in_box(pts, self.needle_start_mm[:2], self.needle_box_mm)
            placed[:, 2] = pts[:, 2] - pts[0, 2] + self.needle_start_mm[2]
            pts = placed
        t = shape_target(pts, self, self.family, name)
        params = {**t.params, "family": "shape", "writable": bool(writable)}
        return dataclasses.replace(t, name=name, params=params)

    def _check_index(self, index: Any, name: str) -> None:
        if not is_index(index):
            raise ConfigError(f"{name} = {index!r}; allowed: an integer")
        if self.target_set == "train":
            raise ConfigError(
                f"{name} = {index!r} selects a named shape: use target_set='validation', "
                "'test' or 'ood_test'"
            )
        n = self.set_sizes[self.target_set]
        if not 0 <= index < n:
            raise ConfigError(
                f"{name} = {index!r}; the {self.target_set} set of {self.env_id} has {n} "
                f"shapes: allowed 0..{n - 1}"
            )

    def fixed_set_target(self, target_set: str, index: int) -> Target:
        """Named shape ``index`` of a held-out set."""
        return self.named[target_set][index]

    def _choose_target(self, options: dict[str, Any]) -> tuple[Target, int]:
        if "target" in options:
            t = options["target"]
            if not isinstance(t, Target):
                raise TypeError("options['target'] must be a bathprint.envs.targets.Target")
            return t, -1
        if self.fixed_target is not None:
            return self.fixed_target, -1
        if self.target_set != "train":
            index = options.get("target_index", self.target_index)
            if index is not None:
                self._check_index(index, "options['target_index']")
            else:
                index = self._eval_cursor % self.set_sizes[self.target_set]
                self._eval_cursor += 1
            return self.named[self.target_set][int(index)], int(index)
        shape = self.generator.sample(self.np_random)
        target = self._train_targets.get(shape.key)
        if target is None:  # placed and sampled once per shape and environment
            target = self.shape_target(shape.points_mm, shape.name, True)
            if len(self._train_targets) >= 1024:
                self._train_targets.pop(next(iter(self._train_targets)))
            self._train_targets[shape.key] = target
        return target, -1

    # ------------------------------------------------------------------ observation
    def _init_observation(self) -> None:
        ob = self.spec_data.observation
        self.obs_density_ref = float(ob.get("density_ref_kg_m3", OBS_DENSITY_REF_KG_M3))
        self.obs_density_scale = float(ob.get("density_scale_kg_m3", OBS_DENSITY_SCALE_KG_M3))
        self.scores_density = self.family == "buoyant"
        self.scores_shape = not self.scores_density
        self.observes_density = self.scores_density or "q_inner" in self.action_names
        feats = ["density_lo", "density_hi"] if self.scores_density else ["curvature", "torsion"]
        self.target_feature_names = feats
        layout: list[tuple[str, int]] = [
            ("tip_relative_positions", 3 * len(TIP_OFFSETS_MM)),
            ("velocities", 3 * len(VEL_OFFSETS_MM)),
            ("printed_curvature", len(CURV_OFFSETS_MM)),
        ]
        if self.observes_density:
            layout.append(("printed_density", len(DENS_OFFSETS_MM)))
        layout.append(("target", len(feats) * len(TARGET_OFFSETS_MM)))
        layout.append(("controls", len(self.action_names)))
        if self.inner_lag_s > 0:
            layout.append(("inner_fraction_now", 1))
        if self.needle_axes:
            layout.append(("needle_position", len(self.needle_axes)))
        layout.append(("progress", 3))
        offsets = ob.get("target_positions_mm", [])
        self._obs_tpos_off = np.asarray(offsets, np.float64)
        if len(offsets):
            layout.append(("target_positions", 3 * len(offsets)))
        self.obs_layout: tuple[tuple[str, int], ...] = tuple(layout)
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
        size = sum(n for _, n in layout)
        self.observation_space = spaces.Box(-OBS_CLIP, OBS_CLIP, (size,), np.float32)

    def _prepare_target(self) -> None:
        tgt = self.target
        assert tgt is not None
        if self.scores_density:
            ref, scale = self.obs_density_ref, self.obs_density_scale
            cols = [
                np.clip((tgt.density_lo_kg_m3 - ref) / scale, -OBS_CLIP, OBS_CLIP),
                np.clip((tgt.density_hi_kg_m3 - ref) / scale, -OBS_CLIP, OBS_CLIP),
            ]
        else:
            cols = [tgt.curvature_1_mm * OBS_CURVATURE_MM, tgt.torsion_1_mm * OBS_CURVATURE_MM]
        self._target_features = np.ascontiguousarray(np.stack(cols, axis=1), np.float64)
        from bathprint.envs.shape_files import target_reference

        self._reference = np.ascontiguousarray(target_reference(self, tgt, self.family))
        self._episode_length_mm = self.episode_length_mm
        self._target_key = tgt.key
        self._prepared_target = tgt

    def _observe(self) -> np.ndarray:
        tgt = self.target
        assert tgt is not None
        extra = self._control_extras()
        n, j = tgt.n_samples, self._n_scored
        extra += [
            self._printed_mm / self._episode_length_mm,
            j / n,
            self._prefix_rms / self.missing_error_mm,
        ]
        if self._obs_tpos_off.size:
            extra += self._target_positions()
        return self._observation(extra)

    # ------------------------------------------------------------------ scoring
    @property
    def reference_curve(self) -> np.ndarray:
        """The curve the written one is compared with (mm; a copy): the target's centreline,
        with the heights its density band settles at for ``buoyant``. It exists from the
        first ``reset`` on; plots and analyses read it to put the target beside what was
        written."""
        if getattr(self, "_prepared_target", None) is None:
            raise RuntimeError("call reset() before reading reference_curve")
        return self._reference.copy()

    def written_curve(self) -> np.ndarray:
        """The recorded samples as the family compares them (mm): positions, or for
        ``buoyant`` the target's path with each sample's settling height."""
        from bathprint.envs.shape_files import written_curve

        return written_curve(self, self.family)

    def _potential(self) -> float:
        """Phi of the scored prefix (module doc); sets ``_prefix_rms`` and ``_prefix_max``."""
        n, j, m2 = self.target.n_samples, self._n_scored, self.missing_error_mm**2
        if j >= 2:
            if self.family == "buoyant":  # written_curve(), into a buffer of this episode
                top, bottom = self.bath_range
                w = self._written_buf[:j]
                w[:, :2] = self.target.points_mm[:j, :2]
                w[:, 2] = (
                    -(np.clip(self._rec_rho[:j], top, bottom) - top)
                    / (bottom - top)
                    * float(self.depth_mm)
                )
            else:  # the recorded samples as they are (no copy)
                w = self._rec_pts[:j]
            d2 = np.empty(j)
            ref = self._reference[:j]
            sq, largest, capped = prefix_error_sums(w, ref, MOTIONS[self.family], m2, d2)
            self._prefix_rms = math.sqrt(sq / j)
            self._prefix_max = math.sqrt(largest)
            total = capped + (n - j) * m2
        else:
            self._prefix_rms = self._prefix_max = 0.0
            total = n * m2
        return -total / n / self.length_scale_mm**2

    def _final(self) -> tuple[float, dict[str, Any]]:
        """Phi at the end and what info reports: the whole-shape error of the written curve
        (the reported metric) and the local metric of version 1."""
        err = shape_error(self.written_curve(), self._reference, self.family)
        self._prefix_rms, self._prefix_max = err.rms_mm, err.max_mm
        phi = -min(err.rms_mm**2, self.missing_error_mm**2) / self.length_scale_mm**2
        tgt = self.target
        prep = prepare(tgt, self.metric_params, self.bath_range)
        j = self._n_scored
        local = float(metric_errors(self._rec_pts[:j], self._rec_rho[:j], *prep.args)[1])
        return phi, {"is_success": bool(err.success), "local_metric": local}

    # ------------------------------------------------------------------ episode
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        options = dict(options or {})
        if seed is not None:
            self._eval_cursor = 0
        drawn = int(self.np_random.integers(self.n_start_states))
        self.target, self._target_index = self._choose_target(options)
        self._target_source = (
            "option" if "target" in options else "file" if self.fixed_target else self.target_set
        )
        start = options.get("start_state", drawn)
        if not (is_index(start) and 0 <= start < self.n_start_states):
            raise ConfigError(
                f"options['start_state'] = {start!r}; allowed 0..{self.n_start_states - 1}"
            )
        self._begin_episode(int(start))
        self._written_buf = np.zeros((self.target.n_samples, 3))
        self._snapshot()
        if getattr(self, "_prepared_target", None) is not self.target:
            self._prepare_target()
        self._phi = self._potential()
        self._end: dict[str, Any] = {}
        obs = self._observe()
        self._last_obs = obs
        if self.render_mode == "human":
            self.render()
        return obs.copy(), self._info()

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self.sim is None:
            raise RuntimeError("call reset() before step()")
        c = self.action_to_controls(action)
        if self._diverged:
            info = self._info()
            info["sim_error"] = self._error_message
            return self._last_obs.copy(), 0.0, False, True, info
        t_end = self._apply_controls(c)
        self._steps += 1
        try:
            advance_to(self.sim, t_end, self.max_substeps)
            self._snapshot()
        except SimulationError as exc:
            return self._diverge(exc)
        self._record()
        terminated = self._printed_mm >= self._episode_length_mm - 1e-6
        if terminated:
            phi, self._end = self._final()
        else:
            phi = self._potential()
        reward = phi - self._phi
        self._phi = phi
        obs = self._observe()
        self._last_obs = obs
        if self.render_mode == "human":
            self.render()
        return obs.copy(), float(reward), bool(terminated), False, self._info()

    def _diverge(
        self, exc: SimulationError
    ) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """End the episode where the simulation diverged (truncated; module doc)."""
        self._diverged = True
        self._error_message = str(exc)
        phi = -2.0 * self.missing_error_mm**2 / self.length_scale_mm**2
        reward, self._phi = phi - self._phi, phi
        info = self._info()
        info["sim_error"] = self._error_message
        info["sim_error_cause"] = exc.cause
        return self._last_obs.copy(), float(reward), False, True, info

    def _info(self) -> dict[str, Any]:
        assert self.sim is not None and self.target is not None
        c = self._controls
        n = self.target.n_samples
        info = {
            "metric": self._prefix_rms,
            "rms_mm": self._prefix_rms,
            "max_mm": self._prefix_max,
            "shape_family": self.family,
            "scored_fraction": self._n_scored / n,
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
            "target_name": self.target.name,
            "target_writable": bool(self.target.params.get("writable", True)),
            "target_set": self._target_source,
            "target_index": self._target_index,
            "start_state": self._start_index,
        }
        info.update(self._end)
        return info

    # ------------------------------------------------------------------ state
    def get_state(self) -> dict[str, Any]:
        """Everything the episode's future depends on, for :meth:`set_state` (planners)."""
        return {
            **self._printing_state(),
            "phi": self._phi,
            "prefix": (self._prefix_rms, self._prefix_max),
            "end": dict(self._end),
        }

    def set_state(self, state: dict[str, Any]) -> None:
        """Continue from a :meth:`get_state` snapshot."""
        self._restore_printing_state(state)
        self._written_buf = np.zeros((self.target.n_samples, 3))
        self._phi = state["phi"]
        self._prefix_rms, self._prefix_max = state["prefix"]
        self._end = dict(state["end"])
        if getattr(self, "_prepared_target", None) is not self.target:
            self._prepare_target()
        if not self._diverged:
            self._snapshot()
