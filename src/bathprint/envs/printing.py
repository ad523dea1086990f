"""What the printing environments (version 1 and the shape environments) share:
:class:`PrintingEnv`, the protocol of a step on :class:`~bathprint.envs.base.BathprintEnvBase`.

A step holds the action's flows (``q_outer`` on the spec's scale, ``q_inner`` as a flow or as
the inner fraction phi, with an optional first-order lag of the oil flow,
``control.inner_lag_s``), the inclusion offset and the needle's velocity (kept in its box)
for the time that extrudes ``control.length_mm`` of filament. Target sample 0 lies
``episode.lead_in_mm`` of material after the first action's; a sample is recorded when it
becomes scored, ``episode.settle_length_mm`` behind the tip, and never changes after. Each
version says what its targets are, what it observes and what it rewards.
"""

from __future__ import annotations

import math
import pickle
from typing import Any

import numpy as np
from gymnasium import spaces

from bathprint.envs._kernels import printed_at
from bathprint.envs._kernels_v1 import observe_v1, record_samples
from bathprint.envs.base import ML_MIN, MM, BathprintEnvBase, move_needle_within, set_flows
from bathprint.envs.metric import MetricParams, PrintedSamples
from bathprint.envs.observation import (
    CURV_INDEX,
    OBS_CLIP,
    OBS_CURVATURE_MM,
    OBS_LENGTH_MM,
    QUERY_MM,
    TARGET_OFFSETS_MM,
    TIP_OFFSETS_MM,
    VEL_OFFSETS_MM,
    layout_slices,
)
from bathprint.envs.targets import FREE_DENSITY
from bathprint.errors import ConfigError

_INNER_LAG_ITERATIONS = 4  # fixed-point iterations for a step's duration under the lag


class PrintingEnv(BathprintEnvBase):
    """Controls, recording and the target near the needle, for every version from 1 on
    (module doc). A subclass sets the target (``self.target``), its observation layout and
    its reward."""

    def _init_episode(self) -> None:
        """Lengths and budgets of an episode, the metric and success (the spec's
        ``[episode]``, ``[metric]``, ``[success]``)."""
        sd = self.spec_data
        ep = sd.episode
        self.lead_in_mm = float(ep.get("lead_in_mm", 0.0))
        self.settle_length_mm = float(ep.get("settle_length_mm", 20.0))
        self.warmup_length_mm = float(ep.get("warmup_length_mm", 30.0))
        self.n_start_states = int(ep.get("start_states", 1))
        self.max_substeps = int(ep.get("max_substeps", 2000))
        self.metric_params = MetricParams.from_dict(sd.metric)
        self.success_metric_max = float(sd.success.get("metric_max", 0.1))

    def _init_controls(self, needle_velocity: bool | str | None) -> None:
        ctl = self.spec_data.control
        self.control_length_mm = float(ctl["length_mm"])
        self.q_outer_range = tuple(float(x) for x in ctl["q_outer_ml_min"])
        self.q_outer_log = ctl.get("q_outer_scale", "linear") == "log"
        self.inner_as_fraction = ctl.get("q_inner_as", "flow") == "fraction"
        self.q_inner_range = tuple(float(x) for x in ctl.get("q_inner_ml_min", [0.0, 0.0]))
        self.inner_fraction_range = tuple(float(x) for x in ctl.get("inner_fraction", [0.0, 0.0]))
        self.inner_lag_s = float(ctl.get("inner_lag_s", 0.0))
        self.offset_range = tuple(float(x) for x in ctl.get("inclusion_offset", [0.0, 0.0]))
        base = list(ctl["actions"])
        inner_hi = self.inner_fraction_range[1] if self.inner_as_fraction else self.q_inner_range[1]
        if "q_inner" in base and inner_hi > 0 and not self.has_inclusions:
            raise ConfigError(f"{self.env_id}: the q_inner action needs the 'inclusions' effect")
        default_axes = str(ctl.get("needle", ""))
        if needle_velocity is None:
            axes = default_axes
        elif needle_velocity is True:
            axes = "xyz"
        else:
            axes = str(needle_velocity) if needle_velocity else ""
        self.needle_axes = axes
        self.default_action_names = base + [f"needle_v{a}" for a in default_axes]
        self.action_names = base + [f"needle_v{a}" for a in axes]
        self._action_index = {name: k for k, name in enumerate(self.action_names)}
        self.needle_speed_mm_s = float(ctl.get("needle_speed_mm_s", 10.0))
        box = np.array(ctl.get("needle_box_mm", [[-20, 20], [-20, 20], [-40, -2]]), float)
        self.needle_box_mm = box.reshape(3, 2)
        self.action_space = spaces.Box(-1.0, 1.0, (len(self.action_names),), np.float32)

    def obs_slices(self) -> dict[str, slice]:
        """Name -> slice of the (flat) observation vector."""
        return layout_slices(self.obs_layout)

    def action_to_controls(self, action: np.ndarray) -> dict[str, Any]:
        """Physical controls of an action (validated and clipped): flows in ml/min (the
        commanded inner flow), inner fraction, offset, needle velocity in mm/s (3 components),
        and the clipped action itself."""
        a = np.asarray(action, dtype=np.float64)
        if a.shape != self.action_space.shape:
            raise ValueError(f"action shape {a.shape}; expected {self.action_space.shape}")
        values = a.tolist()
        if not all(map(math.isfinite, values)):
            raise ValueError(f"action {a!r} holds NaN or inf")
        values = [min(max(x, -1.0), 1.0) for x in values]
        index = self._action_index

        def unit(name: str) -> float:
            return 0.5 * (values[index[name]] + 1.0)

        lo, hi = self.q_outer_range
        f = unit("q_outer")
        qo = (
            math.exp(math.log(lo) + f * (math.log(hi) - math.log(lo)))
            if self.q_outer_log
            else (lo + f * (hi - lo))
        )
        qi = 0.0
        if "q_inner" in index:
            if self.inner_as_fraction:
                p_lo, p_hi = self.inner_fraction_range
                phi = p_lo + unit("q_inner") * (p_hi - p_lo)
                qi = phi / (1.0 - phi) * qo
            else:
                qi = self.q_inner_range[0] + unit("q_inner") * (
                    self.q_inner_range[1] - self.q_inner_range[0]
                )
        qi = min(qi, self.phi_max / (1.0 - self.phi_max) * qo * (1.0 - 1e-9))
        off = None
        if "inclusion_offset" in index:
            o_lo, o_hi = self.offset_range
            off = o_lo + unit("inclusion_offset") * (o_hi - o_lo)
        vel = np.zeros(3)
        for axis in self.needle_axes:
            vel["xyz".index(axis)] = values[index[f"needle_v{axis}"]] * self.needle_speed_mm_s
        return {
            "q_outer_ml_min": qo,
            "q_inner_ml_min": qi,
            "inner_fraction": qi / (qo + qi),
            "inclusion_offset": off,
            "vel": vel,
            "action": values,
        }

    def controls_to_action(self, q_outer_ml_min: float, q_inner_ml_min: float = 0.0) -> np.ndarray:
        """The action that sets these flows (other components 0: offset mid-range, needle
        still); the inverse of :meth:`action_to_controls`."""

        def inv(x: float, lo: float, hi: float) -> float:
            return 0.0 if hi <= lo else 2.0 * (x - lo) / (hi - lo) - 1.0

        a = np.zeros(self.action_space.shape, np.float32)
        lo, hi = self.q_outer_range
        if self.q_outer_log:
            a[0] = inv(math.log(max(q_outer_ml_min, 1e-300)), math.log(lo), math.log(hi))
        else:
            a[0] = inv(q_outer_ml_min, lo, hi)
        if "q_inner" in self.action_names:
            k = self.action_names.index("q_inner")
            if self.inner_as_fraction:
                phi = q_inner_ml_min / (q_outer_ml_min + q_inner_ml_min)
                a[k] = inv(phi, *self.inner_fraction_range)
            else:
                a[k] = inv(q_inner_ml_min, *self.q_inner_range)
        return np.clip(a, -1, 1)

    def step_duration_s(self, action: np.ndarray) -> float:
        """Time (s) a step with this action takes (commanded flows; no ramp, no lag)."""
        c = self.action_to_controls(action)
        q = (c["q_outer_ml_min"] + c["q_inner_ml_min"]) * ML_MIN
        return self.control_length_mm * MM * self.needle_area / q

    @property
    def printed_mm(self) -> float:
        """Filament printed since the episode's start state (mm): the lead-in, then the
        target's arclength, then the settling length."""
        return float(self._printed_mm)

    @property
    def needle_mm(self) -> np.ndarray:
        """Needle tip position now (mm, a copy)."""
        return self._needle_mm.copy()

    @property
    def steps_taken(self) -> int:
        """Steps since the last reset."""
        return int(self._steps)

    @property
    def inner_flow_now_ml_min(self) -> float:
        """The oil flow at the end of the last step (ml/min; under ``control.inner_lag_s``
        it lags its command)."""
        return float(self._inner_now_ml_min)

    @property
    def episode_length_mm(self) -> float:
        """Printed length of a full episode: lead-in, target and settling length (mm)."""
        assert self.target is not None
        return self.lead_in_mm + self.target.length_mm + self.settle_length_mm

    def steps_for_length(self, target_length_mm: float) -> int:
        """Steps of an episode whose target is this long."""
        total = self.lead_in_mm + target_length_mm + self.settle_length_mm
        return int(math.ceil(total / self.control_length_mm - 1e-9))

    def _inner_flow(self, qo: float, q_cmd: float, cap: float) -> float:
        """The oil flow (ml/min) the step extrudes at: the command, or under the lag
        (``control.inner_lag_s``) its mean over the step (a fixed point: the step's duration
        depends on the flow)."""
        tau = self.inner_lag_s
        if not tau > 0:
            return q_cmd
        ds = self.control_length_mm * MM * self.needle_area  # volume to extrude (m^3)
        q0, qi = self._inner_now_ml_min, q_cmd
        for _ in range(_INNER_LAG_ITERATIONS):
            dt_est = ds / ((qo + qi) * ML_MIN)
            qi = q_cmd + (q0 - q_cmd) * tau / dt_est * (1.0 - math.exp(-dt_est / tau))
        return min(max(qi, 0.0), cap)

    def _apply_controls(self, c: dict[str, Any]) -> float:
        """Set the simulation to the step's controls ``c`` (flows, the lagged oil flow,
        offset, needle velocity clipped to the box; ``c`` is updated with what is applied)
        and return the time (s) the step ends at."""
        sim = self.sim
        assert sim is not None
        old = self._controls
        qo = c["q_outer_ml_min"]
        ds = self.control_length_mm * MM * self.needle_area  # volume to extrude (m^3)
        cap = self.phi_max / (1.0 - self.phi_max) * qo * (1.0 - 1e-9)
        qi = self._inner_flow(qo, c["q_inner_ml_min"], cap)
        t0 = sim.t
        dt = set_flows(sim, qo, qi, old["q_outer_ml_min"], old["q_inner_ml_min"], ds)
        tau = self.inner_lag_s
        if tau > 0:
            q_cmd = c["q_inner_ml_min"]
            q_end = q_cmd + (self._inner_now_ml_min - q_cmd) * math.exp(-dt / tau)
            self._inner_now_ml_min = min(max(q_end, 0.0), cap)
        c["q_inner_command_ml_min"] = c["q_inner_ml_min"]
        c["q_inner_ml_min"] = qi
        c["inner_fraction"] = qi / (qo + qi)
        if c["inclusion_offset"] is not None and c["inclusion_offset"] != old["inclusion_offset"]:
            sim.set_inclusion_offset(c["inclusion_offset"])
        t1 = t0 + dt
        if self.needle_axes:
            self._needle_mm, c["vel"] = move_needle_within(
                sim, self._needle_mm, c["vel"], dt, self.needle_box_mm, t1
            )
        self._controls = c
        return t1

    def _scored(self) -> int:
        """Number of target samples printed and settled (scored)."""
        assert self.target is not None
        s_f = self._printed_mm - self.lead_in_mm - self.settle_length_mm
        n = int(math.floor(s_f / self.target.spacing_mm + 1e-9)) + 1
        return max(0, min(n, self.target.n_samples))

    def _record(self) -> None:
        """Record the samples scored in this step (they keep these values)."""
        j = self._scored()
        self._n_scored_prev = self._n_scored
        if j > self._n_scored:
            record_samples(
                self._u,
                self._x,
                self._rho,
                self._origin_mm,
                self.target.spacing_mm,
                self._n_scored,
                j,
                self._rec_pts,
                self._rec_rho,
            )
            self._n_scored = j

    def recorded_samples(self) -> tuple[np.ndarray, np.ndarray]:
        """Positions (J, 3) mm and densities (J,) kg/m^3 of the scored samples (copies)."""
        j = self._n_scored
        return self._rec_pts[:j].copy(), self._rec_rho[:j].copy()

    def printed_samples(self) -> PrintedSamples:
        """The scored part of the filament as it is now (version 0's meaning: drawing, coil
        measurements), with the recorded densities; the metric and the reward use
        :meth:`recorded_samples`."""
        j = self._n_scored
        pts, _ = printed_at(self._u, self._x, self._rho, self._origin_mm, self.target.spacing_mm, j)
        return PrintedSamples(pts, self._rec_rho[:j].copy())

    def _target_positions(self) -> list[float]:
        """The target's centreline at ``observation.target_positions_mm`` of arclength from
        the sample the needle extrudes now (the nearest sample, clamped to the target's
        ends, as the target features are read), relative to the needle, in units of
        OBS_LENGTH_MM: where the target lies in the bath, which its curvature and torsion
        do not say (an S and a C have the same curvature)."""
        tgt = self.target
        assert tgt is not None
        s = (self._printed_mm - self.lead_in_mm + self._obs_tpos_off) / tgt.spacing_mm
        k = np.clip(np.rint(s), 0, tgt.n_samples - 1).astype(np.int64)
        rel = (tgt.points_mm[k] - self._needle_mm[None, :]) / OBS_LENGTH_MM
        return rel.ravel().tolist()

    def target_ahead(self, obs: np.ndarray, lead_mm: float = 0.0) -> dict[str, float]:
        """The target features an observation shows at ``lead_mm`` (one of
        ``TARGET_OFFSETS_MM``) ahead of the tip, decoded: curvature and torsion (1/mm),
        density band (kg/m^3; the bounds read at the observation's clip)."""
        if self.goal_conditioned:
            raise ValueError("the goal-conditioned observation has no target features")
        col = TARGET_OFFSETS_MM.index(lead_mm)
        nf = len(self.target_feature_names)
        row = np.asarray(obs, np.float64)[self.obs_slices()["target"]].reshape(-1, nf)[col]
        out = {
            "curvature_1_mm": 0.0,
            "torsion_1_mm": 0.0,
            "density_lo_kg_m3": FREE_DENSITY[0],
            "density_hi_kg_m3": FREE_DENSITY[1],
        }
        for name, value in zip(self.target_feature_names, row, strict=True):
            if name in ("curvature", "torsion"):
                out[f"{name}_1_mm"] = float(value) / OBS_CURVATURE_MM
            else:
                out[f"{name}_kg_m3"] = float(value) * self.obs_density_scale + self.obs_density_ref
        return out

    # ------------------------------------------------------------------ episode state
    def _begin_episode(self, start_index: int) -> None:
        """Load warm-up state ``start_index`` and reset the controls, the needle and the
        recording for ``self.target`` (a reset, after the target is chosen)."""
        self._start_index = int(start_index)
        self.sim = pickle.loads(self._start_state(self._start_index))
        self._u0_mm = float(np.sum(self.sim.rest_lengths())) / MM
        self._origin_mm = self._u0_mm + self.lead_in_mm
        warm = {"q_outer_ml_min": self.warmup_q_outer, "q_inner_ml_min": 0.0}
        self._controls = {
            **warm,
            "inner_fraction": 0.0,
            "inclusion_offset": float(self.sim.model.p.inclusion_offset),
            "vel": np.zeros(3),
            "action": self.controls_to_action(self.warmup_q_outer, 0.0).tolist(),
        }
        self._inner_now_ml_min = 0.0
        self._needle_mm = self.needle_start_mm.copy()
        self._steps = 0
        self._diverged = False
        n = self.target.n_samples
        self._rec_pts = np.zeros((n, 3))
        self._rec_rho = np.zeros(n)
        self._n_scored = 0
        self._n_scored_prev = 0

    def _control_extras(self) -> list[float]:
        """The observation's controls block: the last action, the lagged inner fraction (under
        ``control.inner_lag_s``) and the needle's place in its box, each in [-1, 1]."""
        c = self._controls
        extra = list(c["action"])
        if self.inner_lag_s > 0:
            qo, qi = c["q_outer_ml_min"], self._inner_now_ml_min
            p_lo, p_hi = self.inner_fraction_range
            phi = qi / (qo + qi)
            extra.append(0.0 if p_hi <= p_lo else 2.0 * (phi - p_lo) / (p_hi - p_lo) - 1.0)
        for axis in self.needle_axes:
            k = "xyz".index(axis)
            lo, hi = self.needle_box_mm[k]
            extra.append(0.0 if hi <= lo else 2.0 * (self._needle_mm[k] - lo) / (hi - lo) - 1.0)
        return extra

    def _printing_state(self) -> dict[str, Any]:
        """What every printing environment's future depends on (the simulation pickled):
        the part of :meth:`get_state` the versions share."""
        assert self.sim is not None
        return {
            "sim": pickle.dumps(self.sim),
            "target": self.target,
            "target_index": self._target_index,
            "target_source": self._target_source,
            "start_index": self._start_index,
            "u0": self._u0_mm,
            "controls": {**self._controls, "vel": self._controls["vel"].copy()},
            "inner_now": self._inner_now_ml_min,
            "needle_mm": self._needle_mm.copy(),
            "steps": self._steps,
            "diverged": self._diverged,
            "error": getattr(self, "_error_message", ""),
            "rec_pts": self._rec_pts.copy(),
            "rec_rho": self._rec_rho.copy(),
            "n_scored": self._n_scored,
            "n_scored_prev": self._n_scored_prev,
            "last_obs": self._last_obs.copy(),
        }

    def _restore_printing_state(self, state: dict[str, Any]) -> None:
        """The inverse of :meth:`_printing_state`."""
        self.sim = pickle.loads(state["sim"])
        self.target = state["target"]
        self._target_index = state["target_index"]
        self._target_source = state["target_source"]
        self._start_index = state["start_index"]
        self._u0_mm = state["u0"]
        self._origin_mm = self._u0_mm + self.lead_in_mm
        self._controls = {**state["controls"], "vel": state["controls"]["vel"].copy()}
        self._inner_now_ml_min = state["inner_now"]
        self._needle_mm = state["needle_mm"].copy()
        self._steps = state["steps"]
        self._diverged = state["diverged"]
        self._error_message = state["error"]
        self._rec_pts = state["rec_pts"].copy()
        self._rec_rho = state["rec_rho"].copy()
        self._n_scored = state["n_scored"]
        self._n_scored_prev = state["n_scored_prev"]
        self._last_obs = state["last_obs"].copy()

    def _observation(self, extra: list[float]) -> np.ndarray:
        """The observation (float32, clipped): the filament near the tip, its curvature and
        densities, the target's features around the needle's sample
        (``self._target_features``), then ``extra`` (each version's controls, progress and
        target positions)."""
        return observe_v1(
            self._x,
            self._v,
            self._u,
            self._rho,
            QUERY_MM,
            len(TIP_OFFSETS_MM),
            len(VEL_OFFSETS_MM),
            CURV_INDEX,
            self._obs_dens_off,
            self._obs_scales,
            self._target_features,
            self._obs_tgt_off,
            self._printed_mm - self.lead_in_mm,
            self.target.spacing_mm,
            np.array(extra),
            OBS_CLIP,
        )
