"""Robustness options for the environments of version 1 on: physics drawn per episode, noise.

Domain randomisation (Tobin et al. 2017, "Domain randomization for transferring deep neural
networks from simulation to the real world", IROS): a policy trained on many variants of the
simulated printer, each episode with its own bath viscosity, gel stiffness and pump lag and
with noisy flows and observations, has to work across them, so it has a better chance on the
real printer, whose parameters are known only roughly. Every option is off by default;
:class:`RobustnessWrapper` with all of them off is the bare environment, step for step.

Options (:class:`Robustness`):

- ``bath_viscosity_spread`` s (-): the bath's viscosity mu drawn log-uniformly in
  [mu/(1+s), mu(1+s)] per episode. The drag coefficient mu_s that the scene derives from
  it at build (Cox's 2 pi mu / ln(L/r), or mu itself for ``drag.model = "constant"`` with
  no coefficient of its own) is derived again; a constant of the scene's own stays.
- ``gel_modulus_spread`` s (-): one factor, drawn the same way, on the gel's moduli (initial
  and final, and the surface model's shell and core; the exit modulus when gelation is off)
  and on the modulus of the filament already printed, so the material is as if it had had
  that stiffness all along (the curvature memory weighs by modulus ratios, which a common
  factor leaves alone).
- ``pump_lag_s`` (lo, hi) s: the oil pump's time constant drawn uniformly per episode;
  environments with an inner flow under a lag only (BuoyantLayers-v1, -v2).
- ``flow_noise`` (-): the alginate flow Q_o of each step multiplied by 1 + sigma z, z standard
  normal clipped to +-3, through the action's q_outer component (log or linear, as the
  environment maps it; clipped to the flow range); the observation keeps showing the
  agent's own action, as a real controller knows its command and not the pump's error.
- ``observation_noise`` (-): Gaussian noise of this standard deviation on every entry of
  the flat observation (the ``observation`` entry of the goal-conditioned dict), clipped to
  the observation space.

The draws come from the wrapper's own generator, seeded from the reset's seed (an unseeded
first reset seeds it from the operating system, as Gymnasium does): the same seed gives the
same draws and, with the same actions, the same episode. Each episode's parameters are drawn
from one fixed set of numbers whichever options are on, so switching one option on does not
change another's draws, and the per-step noise comes from streams of the episode's own, so
an episode's draws do not depend on how long the previous one lasted. ``info["robustness"]``
reports them (units in the names).

The episode's physics is set on the simulation right after the environment's reset
(:func:`apply_physics`): ``sim.model.p`` (``bath_viscosity``, ``mu_s``,
``gel_*_modulus``, ``exit_youngs_modulus``), the scene the simulation holds (so that it
describes the simulation), the modulus column of the material records, and the stepper's
memory that depends on them (the factorised Jacobian, the lagged nonlocal flow). The kernels
read these each step: drag (``mu_s``, or ``bath_viscosity`` under ``finite_re``), the frozen
tail's lumped drag (made from ``mu_s`` at each step), hydrodynamics (``bath_viscosity``,
copied into its memory at each evaluation), the step bound of buckling (``mu_s`` and the
material's modulus), gelation (the moduli, from the material's age at each accepted step)
and new material at the needle. Not redone: the check of the scene's resolution at load
(a softer gel has a shorter buckling length).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from typing import Any

import gymnasium as gym
import numpy as np

from bathprint.core.layout import MAT_YOUNGS_MODULUS
from bathprint.errors import ConfigError

MAX_SPREAD = 9.0  # a spread draws within a factor 1 + s = 10 either way at most
MAX_FLOW_NOISE = 0.3  # with z clipped to +-3 the flow keeps >= 10% of its command
FLOW_NOISE_CLIP = 3.0  # standard deviations
_SEED_TAG = 0x726F62  # mixed with the reset seed: the wrapper's draws and the env's differ


def _is_number(value: Any) -> bool:
    return (
        isinstance(value, int | float | np.integer | np.floating)
        and not isinstance(value, bool | np.bool_)
        and math.isfinite(float(value))
    )


def _check_range(key: str, value: Any, hi: float, meaning: str) -> float:
    if not (_is_number(value) and 0.0 <= float(value) <= hi):
        raise ConfigError(f"{key} = {value!r}; allowed: a number in [0, {hi:g}] ({meaning})")
    return float(value)


@dataclass(frozen=True)
class Robustness:
    """The robustness options of :class:`RobustnessWrapper` (all off by default; see the
    module doc). Values are checked on construction: a bad one raises
    :class:`~bathprint.errors.ConfigError` naming the key, the value and what is allowed."""

    bath_viscosity_spread: float = 0.0  # -, mu log-uniform in [mu/(1+s), mu(1+s)]
    gel_modulus_spread: float = 0.0  # -, the gel moduli times a log-uniform factor, same
    pump_lag_s: tuple[float, float] | None = None  # s, the oil pump's lag uniform in (lo, hi)
    flow_noise: float = 0.0  # -, relative standard deviation of Q_o per step
    observation_noise: float = 0.0  # standard deviation on the (scaled) observation

    def __post_init__(self) -> None:
        spread = "0: off; 1 + s is the largest factor drawn either way"
        for key in ("bath_viscosity_spread", "gel_modulus_spread"):
            object.__setattr__(self, key, _check_range(key, getattr(self, key), MAX_SPREAD, spread))
        object.__setattr__(
            self,
            "flow_noise",
            _check_range(
                "flow_noise",
                self.flow_noise,
                MAX_FLOW_NOISE,
                "0: off; relative standard deviation of the alginate flow per step",
            ),
        )
        noise = self.observation_noise
        if not (_is_number(noise) and float(noise) >= 0.0):
            raise ConfigError(
                f"observation_noise = {noise!r}; allowed: a number >= 0 (0: off; standard "
                "deviation added to the observation's entries)"
            )
        object.__setattr__(self, "observation_noise", float(noise))
        object.__setattr__(self, "pump_lag_s", _check_lag(self.pump_lag_s))

    @classmethod
    def from_mapping(cls, options: Mapping[str, Any]) -> Robustness:
        """From a mapping of option names to values (an agents file's), unknown names
        refused."""
        if not isinstance(options, Mapping):
            raise ConfigError(
                f"robustness = {options!r}; allowed: a Robustness or a mapping of "
                + ", ".join(cls.keys())
            )
        for key in options:
            if key not in cls.keys():
                raise ConfigError(
                    f"unknown robustness option {key!r}; allowed: " + ", ".join(cls.keys())
                )
        return cls(**options)

    @classmethod
    def keys(cls) -> tuple[str, ...]:
        """The option names."""
        return tuple(f.name for f in fields(cls))

    @property
    def enabled(self) -> bool:
        """Whether any option is on."""
        return bool(
            self.bath_viscosity_spread
            or self.gel_modulus_spread
            or self.pump_lag_s is not None
            or self.flow_noise
            or self.observation_noise
        )

    def as_dict(self) -> dict[str, Any]:
        """The options as plain values (JSON: the lag as a list)."""
        out = {f.name: getattr(self, f.name) for f in fields(self)}
        if self.pump_lag_s is not None:
            out["pump_lag_s"] = list(self.pump_lag_s)
        return out


def _check_lag(value: Any) -> tuple[float, float] | None:
    if value is None:
        return None
    ok = (
        isinstance(value, Sequence | np.ndarray)
        and not isinstance(value, str)
        and len(value) == 2
        and all(_is_number(v) for v in value)
    )
    if ok:
        lo, hi = float(value[0]), float(value[1])
        if 0.0 < lo <= hi:
            return lo, hi
    raise ConfigError(
        f"pump_lag_s = {value!r}; allowed: None (off) or [lo, hi], the range in s the oil "
        "pump's lag is drawn from, 0 < lo <= hi"
    )


def _v1(env: gym.Env) -> Any:
    from bathprint.envs.printing import PrintingEnv

    u = env.unwrapped
    if not isinstance(u, PrintingEnv):
        raise ConfigError(
            f"robustness options on {type(u).__name__}: allowed on the environments of "
            "version 1 on (bathprint.envs.printing.PrintingEnv: CoilRadius-v1/v2, "
            "WriteShape-v1/v2/v3, BuoyantLayers-v1/v2)"
        )
    return u


def _check_lag_env(u: Any, value: Any) -> None:
    """The environment has an inner flow under a lag (its observation then holds the lagged
    inner fraction, whatever the lag's value)."""
    name = getattr(u, "env_id", "") or type(u).__name__
    if "q_inner" not in u.action_names:
        raise ConfigError(
            f"pump_lag_s = {value!r}: {name} has no inner flow (no q_inner action); allowed: None"
        )
    if not u.inner_lag_s > 0:
        raise ConfigError(
            f"pump_lag_s = {value!r}: {name} has no pump lag (control.inner_lag_s = 0, so its "
            "observation has no lagged inner fraction); allowed: None"
        )


def apply_physics(
    env: gym.Env,
    *,
    bath_viscosity_factor: float | None = None,
    gel_modulus_factor: float | None = None,
    pump_lag_s: float | None = None,
) -> dict[str, float]:
    """Set an episode's physics on a version-1 environment right after its reset: the bath's
    viscosity and the gel's moduli times the factors (of the values the simulation has, the
    nominal ones after a reset) and the oil pump's lag in s (None: left as it is). Returns
    the values set, units in the names. :class:`RobustnessWrapper` draws them; a fixed
    value (e.g. a policy scored at twice the viscosity) is set by calling this directly."""
    from bathprint.core.model import slender_body_coefficient

    u = _v1(env)
    sim = u.sim
    if sim is None:
        raise RuntimeError("call reset() before apply_physics()")
    for key, f in (
        ("bath_viscosity_factor", bath_viscosity_factor),
        ("gel_modulus_factor", gel_modulus_factor),
    ):
        if f is not None and not (_is_number(f) and float(f) > 0.0):
            raise ConfigError(f"{key} = {f!r}; allowed: None or a number > 0")
    if pump_lag_s is not None:  # checked before anything changes
        if not (_is_number(pump_lag_s) and float(pump_lag_s) > 0.0):
            raise ConfigError(f"pump_lag_s = {pump_lag_s!r}; allowed: None or a number > 0 (s)")
        _check_lag_env(u, pump_lag_s)
    p = sim.model.p
    scenes = {id(s): s for s in (sim.model.scene, sim.scene)}.values()  # one object, or two
    out: dict[str, float] = {}
    if bath_viscosity_factor is not None:
        mu = float(p.bath_viscosity) * float(bath_viscosity_factor)
        for sc in scenes:
            sc.bath.viscosity_pa_s = mu
        p.bath_viscosity = mu
        p.mu_s = slender_body_coefficient(sim.model.scene, float(p.exit_radius))
        out["bath_viscosity_factor"] = float(bath_viscosity_factor)
        out["bath_viscosity_pa_s"] = mu
        out["slender_body_coefficient_pa_s"] = float(p.mu_s)
    if gel_modulus_factor is not None:
        c = float(gel_modulus_factor)
        if p.gelation:
            p.gel_initial_modulus = float(p.gel_initial_modulus) * c
            p.gel_final_modulus = float(p.gel_final_modulus) * c
            p.gel_shell_modulus = float(p.gel_shell_modulus) * c
            p.gel_core_modulus = float(p.gel_core_modulus) * c
            for sc in scenes:
                gel = sc.gelation
                gel.initial_modulus_pa = float(p.gel_initial_modulus)
                gel.final_modulus_pa = float(p.gel_final_modulus)
                gel.shell_modulus_pa = float(p.gel_shell_modulus)
                gel.core_modulus_pa = float(p.gel_core_modulus)
        else:
            p.exit_youngs_modulus = float(p.exit_youngs_modulus) * c
            for sc in scenes:
                sc.material.youngs_modulus_pa = float(p.exit_youngs_modulus)
        n_seg = max(sim.n_nodes - 1, 0)  # the filament's segments and the ghost's
        sim.seg_mat[:n_seg, MAT_YOUNGS_MODULUS] *= c
        out["gel_modulus_factor"] = c
        if p.gelation:
            out["gel_initial_modulus_pa"] = float(p.gel_initial_modulus)
            out["gel_final_modulus_pa"] = float(p.gel_final_modulus)
        else:
            out["youngs_modulus_pa"] = float(p.exit_youngs_modulus)
    if bath_viscosity_factor is not None or gel_modulus_factor is not None:
        ws = sim.ws
        ws.solver[0]["lu_valid"] = False  # the Jacobian was factorised with the old values
        for flag in ("linearized", "u_valid", "next_valid"):
            ws.hydro.memory[0][flag] = False  # nonlocal flows of the old viscosity
    if pump_lag_s is not None:
        u.inner_lag_s = float(pump_lag_s)
        out["pump_lag_s"] = float(pump_lag_s)
    return out


class RobustnessWrapper(gym.Wrapper, gym.utils.RecordConstructorArgs):
    """A version-1 environment with the robustness options of :class:`Robustness` (give a
    ``Robustness``, a mapping, or the options as keywords, as an agents file does::

        env_wrapper:
          - bathprint.envs.robust.RobustnessWrapper: {bath_viscosity_spread: 0.2}

    ). Wrap the environment itself (what ``gymnasium.make`` returns), inside any wrapper
    that changes the action's meaning. ``info["robustness"]`` holds the episode's draws and
    the step's realised flow factor. The options are recorded in ``env.spec`` (Gymnasium's
    ``additional_wrappers``), so ``gymnasium.make(env.spec)`` makes the wrapped environment."""

    def __init__(
        self,
        env: gym.Env,
        robustness: Robustness | Mapping[str, Any] | None = None,
        *,
        bath_viscosity_spread: float = 0.0,
        gel_modulus_spread: float = 0.0,
        pump_lag_s: tuple[float, float] | None = None,
        flow_noise: float = 0.0,
        observation_noise: float = 0.0,
    ) -> None:
        given = {
            "bath_viscosity_spread": bath_viscosity_spread,
            "gel_modulus_spread": gel_modulus_spread,
            "pump_lag_s": pump_lag_s,
            "flow_noise": flow_noise,
            "observation_noise": observation_noise,
        }
        if robustness is None:
            rob = Robustness(**given)
        else:
            if Robustness(**given).enabled:
                raise ConfigError(
                    f"robustness = {robustness!r} and option keywords: give one of them"
                )
            rob = (
                robustness
                if isinstance(robustness, Robustness)
                else Robustness.from_mapping(robustness)
            )
        u = _v1(env)
        if rob.pump_lag_s is not None:
            _check_lag_env(u, rob.pump_lag_s)
        gym.utils.RecordConstructorArgs.__init__(self, **rob.as_dict())
        gym.Wrapper.__init__(self, env)
        if env.observation_space != u.observation_space:
            raise ConfigError(
                "RobustnessWrapper: the wrapped environment's observation space is not the "
                "environment's own; wrap the environment itself"
            )
        self.robustness = rob
        self._goal = bool(u.goal_conditioned)
        if self._goal:  # the goal-environment interface (the goals carry no noise)
            self.compute_reward = u.compute_reward
        flat = u.observation_space["observation"] if self._goal else u.observation_space
        self._obs_low = np.asarray(flat.low, np.float64)
        self._obs_high = np.asarray(flat.high, np.float64)
        self._obs_dtype = flat.dtype
        self._controls = u.obs_slices()["controls"]
        self._q_outer = u.action_names.index("q_outer")
        self._rng: np.random.Generator | None = None
        self._flow_rng: np.random.Generator | None = None
        self._obs_rng: np.random.Generator | None = None
        self._episode: dict[str, float] = {}

    # ------------------------------------------------------------------ episode
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        obs, info = self.env.reset(seed=seed, options=options)
        if seed is not None:
            self._rng = np.random.default_rng([int(seed), _SEED_TAG])
        elif self._rng is None:
            self._rng = np.random.default_rng()
        draws = self._rng.random(3)  # viscosity, modulus, lag: drawn whichever are on
        episode_seed = int(self._rng.integers(2**63))
        self._flow_rng = np.random.default_rng([episode_seed, 1])
        self._obs_rng = np.random.default_rng([episode_seed, 2])
        rob = self.robustness

        def log_uniform(spread: float, unit: float) -> float | None:
            return math.exp((2.0 * unit - 1.0) * math.log1p(spread)) if spread > 0 else None

        lag = None
        if rob.pump_lag_s is not None:
            lo, hi = rob.pump_lag_s
            lag = lo + float(draws[2]) * (hi - lo)
        self._episode = apply_physics(
            self.env,
            bath_viscosity_factor=log_uniform(rob.bath_viscosity_spread, float(draws[0])),
            gel_modulus_factor=log_uniform(rob.gel_modulus_spread, float(draws[1])),
            pump_lag_s=lag,
        )
        info["robustness"] = dict(self._episode)
        return self._observation(obs), info

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        if self.robustness.flow_noise > 0:
            agent, applied, q_cmd = self._noisy_action(action)
            obs, reward, terminated, truncated, info = self.env.step(applied)
            obs = self._with_flat(obs, lambda x: self._show_command(x, agent))
            factor = float(info["q_outer_ml_min"]) / q_cmd
            info["robustness"] = {**self._episode, "flow_noise_factor": factor}
        else:
            obs, reward, terminated, truncated, info = self.env.step(action)
            info["robustness"] = dict(self._episode)
        return self._observation(obs), reward, terminated, truncated, info

    # ------------------------------------------------------------------ noise
    def _noisy_action(self, action: Any) -> tuple[np.ndarray, np.ndarray, float]:
        """(the agent's action clipped, the action with the step's flow noise, the agent's
        Q_o in ml/min): Q_o times 1 + sigma z, in the q_outer component's own mapping."""
        if self._flow_rng is None:
            raise RuntimeError("call reset() before step()")
        u = self.env.unwrapped
        c = u.action_to_controls(action)  # checks the action as the environment does
        agent = np.asarray(c["action"], np.float64)
        q_cmd = float(c["q_outer_ml_min"])
        z = min(max(float(self._flow_rng.standard_normal()), -FLOW_NOISE_CLIP), FLOW_NOISE_CLIP)
        q = q_cmd * (1.0 + self.robustness.flow_noise * z)
        lo, hi = u.q_outer_range
        if u.q_outer_log:
            q, lo, hi = math.log(q), math.log(lo), math.log(hi)
        applied = agent.copy()
        a = 0.0 if hi <= lo else 2.0 * (q - lo) / (hi - lo) - 1.0
        applied[self._q_outer] = min(max(a, -1.0), 1.0)
        return agent, applied, q_cmd

    def _show_command(self, flat: np.ndarray, agent: np.ndarray) -> np.ndarray:
        """The observation's ``controls`` entry as the agent's action, not the noisy one."""
        out = np.array(flat, copy=True)
        out[self._controls] = agent.astype(out.dtype)
        return out

    def _observation(self, obs: Any) -> Any:
        sigma = self.robustness.observation_noise
        if not sigma > 0:
            return obs
        assert self._obs_rng is not None

        def noisy(flat: np.ndarray) -> np.ndarray:
            x = np.asarray(flat, np.float64) + sigma * self._obs_rng.standard_normal(flat.shape)
            return np.clip(x, self._obs_low, self._obs_high).astype(self._obs_dtype)

        return self._with_flat(obs, noisy)

    def _with_flat(self, obs: Any, fn: Any) -> Any:
        """``fn`` applied to the flat observation (the dict's ``observation`` entry)."""
        if not self._goal:
            return fn(obs)
        return {**obs, "observation": fn(obs["observation"])}
