"""Baseline policies, and loading any policy ``bathprint evaluate`` accepts.

Every policy here has Stable-Baselines3's ``predict`` signature, so evaluation treats a
trained agent and a baseline alike::

    action, state = policy.predict(obs, state=None, episode_start=None, deterministic=True)

(``obs`` one observation or a batch of them.) The baselines:

- :class:`RandomPolicy`: uniform actions in [-1, 1] from its own seeded generator.
- :class:`ConstantPolicy`: one action held for the whole episode; ``bathprint baselines
  fit`` finds the best one per environment by a grid search over constant flows on
  training targets (``agents/baselines.yml``).
- :class:`FeedforwardPolicy`: the paper's scaling law inverted. It reads the target just
  ahead of the needle from the observation (curvature, torsion, density aim; see
  :data:`bathprint.envs.observation.OBS_LAYOUT`) and sets

  * Q_i for the density aim: phi = (rho_gel - rho_aim) / (rho_gel - rho_inner), rho the
    composite's volume-weighted density, and Q_i = phi Q_o / (1 - phi); for an arc (planar
    curvature, no torsion) at least the phi that reaches kappa0 = C Delta phi / r with the
    offset Delta = +-1;
  * Q_o for the coil radius R of the osculating helix of the target:
    R = c (B / (mu v))^(1/3)  =>  v = B c^3 / (mu R^3),  Q_o = (1 - phi) v A,
    with B = f(phi) E pi r^4 / 4 (f: the composite's bending factor, E: the modulus of the
    set gel), mu the bath viscosity, A the needle's bore. c = 0.4 is the paper's prefactor
    (Fig. 2B); the "calibrated" variant uses c fitted on this simulator's own coils
    (``bathprint baselines fit``). Straight pieces and arcs take the smallest Q_o (largest
    radius, the nearest to straight).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from bathprint.envs.observation import (
    OBS_CURVATURE_MM,
    OBS_DENSITY_REF_KG_M3,
    OBS_DENSITY_SCALE_KG_M3,
    TARGET_OFFSETS_MM,
    obs_slices,
)

PAPER_PREFACTOR = 0.4  # R = 0.4 (B / (mu v))^(1/3), the paper's Fig. 2B fit
BASELINES = ("random", "constant", "feedforward", "feedforward_calibrated")
#: baselines of version-1 environments only: the tuned controller of each shape family
#: (bathprint.agents.controller)
V1_BASELINES = ("controller",)
#: planners on the simulator itself (bathprint.agents.planning): seconds to minutes per target
PLANNERS = ("oracle", "mpc", "cem")
#: every policy name ``bathprint evaluate`` knows besides run directories and models
KNOWN = BASELINES + V1_BASELINES + PLANNERS


def baseline_name(spec: str) -> str | None:
    """The baseline or planner a policy spec names (``"mpc:samples=8"`` -> ``"mpc"``; only
    planners take options), or None."""
    name, colon, _ = spec.partition(":")
    if name in PLANNERS or (name in BASELINES + V1_BASELINES and not colon):
        return name
    return None


class Policy(Protocol):
    """What ``bathprint evaluate`` runs: SB3's ``predict``."""

    def predict(
        self,
        observation: np.ndarray,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]: ...


class BatchPolicy:
    """SB3's ``predict`` for a policy that maps a batch of observations to actions."""

    def actions(self, obs: np.ndarray) -> np.ndarray:
        """(n, obs_dim) float64 -> (n, action_dim) float32."""
        raise NotImplementedError

    def predict(
        self,
        observation: np.ndarray,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]:
        obs = np.asarray(observation, np.float64)
        single = obs.ndim == 1
        a = self.actions(obs[None, :] if single else obs)
        return (a[0] if single else a), state


class RandomPolicy(BatchPolicy):
    """Uniform actions in [-1, 1]^n from ``np.random.default_rng(seed)``."""

    def __init__(self, action_dim: int, seed: int = 0) -> None:
        self.action_dim = int(action_dim)
        self.rng = np.random.default_rng(seed)

    def actions(self, obs: np.ndarray) -> np.ndarray:
        return self.rng.uniform(-1.0, 1.0, (len(obs), self.action_dim)).astype(np.float32)


class ConstantPolicy(BatchPolicy):
    """The same action every step."""

    def __init__(self, action: np.ndarray | list[float]) -> None:
        self.action = np.clip(np.asarray(action, np.float32), -1.0, 1.0)

    def actions(self, obs: np.ndarray) -> np.ndarray:
        return np.repeat(self.action[None, :], len(obs), axis=0)


@dataclass(frozen=True)
class LawConstants:
    """What the feedforward controller knows of the printer and bath (SI units)."""

    bending_stiffness_gel: float  # N m^2, E pi r^4 / 4 of the set gel
    bath_viscosity: float  # Pa s
    needle_area: float  # m^2
    filament_radius: float  # m
    rho_gel: float  # kg/m^3
    rho_inner: float  # kg/m^3
    curvature_coefficient: float  # C in kappa0 = C Delta phi / r
    phi_max: float

    @classmethod
    def from_env(cls, env: Any) -> LawConstants:
        u = env.unwrapped
        sim0 = _probe_simulation(u)
        p = sim0.model.p
        E = float(p.gel_final_modulus if p.gelation else p.exit_youngs_modulus)
        r = float(p.exit_radius)
        return cls(
            bending_stiffness_gel=E * math.pi * r**4 / 4.0,
            bath_viscosity=float(sim0.scene.bath.viscosity_pa_s),
            needle_area=float(u.needle_area),
            filament_radius=r,
            rho_gel=float(u.rho_gel),
            rho_inner=float(p.inner_density),
            curvature_coefficient=float(p.curvature_coefficient),
            phi_max=float(u.phi_max),
        )


def _probe_simulation(env: Any) -> Any:
    from bathprint.core.simulation import Simulation

    return Simulation(env.scene_base, env.scene_overrides)


def law_q_outer_ml_min(
    radius_m: float, phi: float, c: LawConstants, prefactor: float = PAPER_PREFACTOR
) -> float:
    """Q_o (ml/min, unclipped) that the scaling law maps to coil radius ``radius_m`` at inner
    fraction ``phi``: v = B(phi) prefactor^3 / (mu R^3), Q_o = (1 - phi) v A."""
    from bathprint.core.composite import stiffness_factors

    if not (radius_m > 0 and math.isfinite(radius_m)):
        raise ValueError(f"radius_m = {radius_m!r}; must be positive and finite")
    bend = stiffness_factors(float(phi), 0.8)[0]
    B = bend * c.bending_stiffness_gel
    v = B * prefactor**3 / (c.bath_viscosity * radius_m**3)
    return (1.0 - phi) * v * c.needle_area * 60.0e6


def law_radius_m(
    q_outer_ml_min: float, phi: float, c: LawConstants, prefactor: float = PAPER_PREFACTOR
) -> float:
    """Coil radius (m) the scaling law gives for Q_o at inner fraction phi (the inverse of
    :func:`law_q_outer_ml_min`)."""
    from bathprint.core.composite import stiffness_factors

    v = q_outer_ml_min / 60.0e6 / ((1.0 - phi) * c.needle_area)
    B = stiffness_factors(float(phi), 0.8)[0] * c.bending_stiffness_gel
    return prefactor * (B / (c.bath_viscosity * v)) ** (1.0 / 3.0)


class FeedforwardPolicy(BatchPolicy):
    """The scaling-law controller of the module docstring (reads only the observation)."""

    def __init__(self, env: Any, prefactor: float = PAPER_PREFACTOR, lead_mm: float = 0.0):
        if not prefactor > 0:
            raise ValueError(f"prefactor = {prefactor!r}; must be > 0")
        if lead_mm not in TARGET_OFFSETS_MM:
            raise ValueError(f"lead_mm = {lead_mm!r}; allowed: {TARGET_OFFSETS_MM}")
        u = env.unwrapped
        if getattr(u, "goal_conditioned", False):
            raise ValueError(
                "the feedforward reads the target from the flat observation: make the "
                "environment with goal_conditioned=False"
            )
        self.env = u
        self.lead_mm = float(lead_mm)
        self.prefactor = float(prefactor)
        self.constants = LawConstants.from_env(env)
        self._col = TARGET_OFFSETS_MM.index(lead_mm)
        self._slice = obs_slices()["target_curvature_torsion_density"]
        self.action_dim = int(u.action_space.shape[0])

    def controls(self, obs: np.ndarray) -> dict[str, float]:
        """Physical controls for one observation: q_outer_ml_min, q_inner_ml_min, offset
        (Delta) and the radius aimed at (mm; inf for straight pieces and arcs)."""
        u, c = self.env, self.constants
        if getattr(u, "version", 0) >= 1:  # version 1: the layout of the environment
            ahead = u.target_ahead(obs, self.lead_mm)
            kappa, tau = ahead["curvature_1_mm"], ahead["torsion_1_mm"]
            rho_aim = min(max(c.rho_gel, ahead["density_lo_kg_m3"]), ahead["density_hi_kg_m3"])
            resolution = 1e-5 * u.obs_density_scale
        else:
            feats = np.asarray(obs, np.float64)[self._slice].reshape(-1, 3)[self._col]
            kappa = feats[0] / OBS_CURVATURE_MM  # 1/mm
            tau = feats[1] / OBS_CURVATURE_MM
            rho_aim = feats[2] * OBS_DENSITY_SCALE_KG_M3 + OBS_DENSITY_REF_KG_M3
            resolution = 1e-5 * OBS_DENSITY_SCALE_KG_M3
        phi = 0.0
        # the aim comes through a float32 feature, which resolves ~3e-6 kg/m^3: below the gel
        # by less than 1e-5 of the density scale is the gel itself
        if c.rho_gel - c.rho_inner > 0 and rho_aim < c.rho_gel - resolution:
            phi = (c.rho_gel - rho_aim) / (c.rho_gel - c.rho_inner)
        offset = 0.0
        is_arc = kappa > 1e-6 and abs(tau) < 1e-6 and "inclusion_offset" in u.action_names
        if is_arc and c.curvature_coefficient > 0:
            phi = max(phi, kappa * 1e3 * c.filament_radius / c.curvature_coefficient)  # Delta=1
        if "q_inner" not in u.action_names:
            phi = 0.0
        phi = float(min(phi, c.phi_max))
        if is_arc and phi > 0:
            offset = float(kappa * 1e3 * c.filament_radius / (c.curvature_coefficient * phi))
        den = kappa * kappa + tau * tau
        radius_mm = kappa / den if (kappa > 1e-6 and abs(tau) > 1e-6) else math.inf
        if math.isfinite(radius_mm):
            qo = law_q_outer_ml_min(radius_mm * 1e-3, phi, c, self.prefactor)
        else:
            qo = u.q_outer_range[0]
        qo = float(np.clip(qo, *u.q_outer_range))
        qi = phi / (1.0 - phi) * qo if phi > 0 else 0.0
        return {
            "q_outer_ml_min": qo,
            "q_inner_ml_min": qi,
            "offset": float(np.clip(offset, -1.0, 1.0)),
            "radius_mm": radius_mm,
        }

    def action(self, obs: np.ndarray) -> np.ndarray:
        u = self.env
        ctl = self.controls(obs)
        a = u.controls_to_action(ctl["q_outer_ml_min"], ctl["q_inner_ml_min"])
        if "inclusion_offset" in u.action_names:
            lo, hi = u.offset_range
            a[u.action_names.index("inclusion_offset")] = (
                0.0 if hi <= lo else 2.0 * (ctl["offset"] - lo) / (hi - lo) - 1.0
            )
        return np.clip(a, -1.0, 1.0).astype(np.float32)

    def actions(self, obs: np.ndarray) -> np.ndarray:
        return np.stack([self.action(o) for o in obs])


class SB3Policy:
    """A trained Stable-Baselines3 model (and its VecNormalize statistics, if any)."""

    def __init__(self, model: Any, obs_normalizer: Any = None, normalization: str = "") -> None:
        self.model = model
        self.obs_normalizer = obs_normalizer
        self.normalization = normalization  # where the observation statistics came from

    def predict(
        self,
        observation: np.ndarray | dict[str, np.ndarray],
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]:
        obs = _float32(observation)
        if self.obs_normalizer is not None and self.obs_normalizer.norm_obs:
            obs = _float32(self.obs_normalizer.normalize_obs(obs))
        return self.model.predict(obs, state, episode_start, deterministic)


def _float32(observation: Any) -> Any:
    """An observation as float32: an array, or a dict of arrays (the goal-conditioned
    environments' ``observation``/``achieved_goal``/``desired_goal``)."""
    if isinstance(observation, dict):
        return {k: np.asarray(v, np.float32) for k, v in observation.items()}
    return np.asarray(observation, np.float32)


def load_policy(spec: str, env: Any, env_id: str, seed: int = 0) -> tuple[Policy, str]:
    """A policy from a baseline name, a run directory or a model ``.zip``; returns it and a
    label. Baselines ``constant`` and ``feedforward_calibrated`` read ``agents/baselines.yml``.
    """
    name = baseline_name(spec)
    if name in PLANNERS:
        from bathprint.agents import planning

        if name == "cem":
            settings = planning.parse_options(spec, planning.ShapeCEMSettings)
            return planning.ShapeCEMPolicy(env, env_id, settings), spec
        if name == "oracle":
            settings = planning.parse_options(spec, planning.CEMSettings)
            return planning.OraclePolicy(env, env_id, settings), spec
        settings = planning.parse_options(spec, planning.MPCSettings)
        return planning.MPCPolicy(env, env_id, settings), spec
    if name is not None:
        from bathprint.agents.hyperparams import load_baselines

        if spec == "random":
            return RandomPolicy(env.action_space.shape[0], seed), spec
        if spec == "feedforward":
            return FeedforwardPolicy(env), spec
        if spec == "controller":
            from bathprint.agents.controller import make_controller

            return make_controller(env), spec
        fitted = load_baselines(env_id)
        if spec == "constant":
            return ConstantPolicy(fitted["constant_action"]), spec
        return FeedforwardPolicy(env, prefactor=float(fitted["feedforward_prefactor"])), spec
    from bathprint.agents.train import load_trained

    path = Path(spec)
    if not path.exists():
        raise FileNotFoundError(
            f"policy {spec!r}: neither a baseline ({', '.join(KNOWN)}) nor an "
            "existing run directory or model .zip"
        )
    model, normalizer, label, note = load_trained(path)
    return SB3Policy(model, normalizer, note), label
