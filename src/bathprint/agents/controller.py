"""``controller``: the tuned classical reference of each shape family.

One controller per family of :mod:`bathprint.envs.shapes`, each the law a printing engineer
would write down, with a few gains tuned on the family's *validation* shapes only
(:func:`tune`; the chosen gains and the whole grid's scores are in
``agents/controller.yml``):

- **floor** (the needle writes; ``WriteShape``): the shape is placed to start under the
  needle, turned about the vertical to keep the largest margin inside the needle's box
  (:func:`~bathprint.envs.shape_geometry.place_in_box`: the family's rigid motions leave it
  unchanged). The needle is steered toward the point of the path whose arclength is the
  filament extruded so far plus ``lead_mm``, at ``gain_1_s`` times the distance (a
  proportional tracker; the needle's speed limit saturates it), at a constant flow
  ``q_outer_ml_min`` (its extrusion speed near the needle's 60 mm/s, the sewing machine's
  "laid straight" regime: Chiu-Webster & Lister 2006, J. Fluid Mech. 569:89). After the
  shape ends, the needle runs on along the last tangent at ``runout`` times the extrusion
  speed, so the end of the shape is laid out rather than coiled on.
- **free** (the needle at rest; ``CoilRadius``): the scaling-law feedforward
  (:class:`~bathprint.agents.policies.FeedforwardPolicy`): Q_o from
  R = c (B / (mu v))^(1/3) for the radius of the osculating helix ``lead_mm`` ahead, with
  the prefactor ``prefactor`` (the paper's Fig. 2B fit is 0.4), times exp(I): I integrates
  ``integral_gain`` x 3 log(kappa_target / kappa_printed) each step, the curvature printed
  4 mm behind the tip against the target's there (kappa ~ v^(1/3) by the same law).
- **buoyant** (the inner fluid sets the density; ``BuoyantLayers``): the oil fraction that
  makes the composite as dense as the bath at the target height ``lead_mm`` ahead, through
  a dead-beat inverse of the pump's first-order lag (the command that brings the lagging
  oil flow to its aim by the end of the step, times ``gain``, clipped to the pump's range),
  at the smallest alginate flow ``q_outer_ml_min`` (the slower the filament, the less of it
  a change of density smears over).

Every controller has Stable-Baselines3's ``predict`` signature and reads the environment
it drives (its target, the filament printed, the needle, the lagging oil flow): what a
printer's own controller knows. None reads the controls that printed a target.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from bathprint.envs.shapes import family_shapes  # noqa: F401  (re-exported)
from bathprint.errors import ConfigError

#: the environment each family is written in (the benchmark's pairing)
FAMILY_ENVS: dict[str, str] = {
    "floor": "bathprint/WriteShape-v3",
    "free": "bathprint/CoilRadius-v2",
    "buoyant": "bathprint/BuoyantLayers-v2",
}


@dataclass(frozen=True)
class FloorGains:
    """Needle tracking: gain (1/s), look-ahead (mm of arclength), flow (ml/min), run-out."""

    gain_1_s: float = 80.0
    lead_mm: float = 0.0
    q_outer_ml_min: float = 0.45
    runout: float = 1.0


@dataclass(frozen=True)
class FreeGains:
    """Scaling-law feedforward (prefactor c, look-ahead in mm: a target offset the
    observation shows) with integral feedback on the printed curvature (gain per step)."""

    prefactor: float = 0.4
    lead_mm: float = 0.0
    integral_gain: float = 0.0


@dataclass(frozen=True)
class BuoyantGains:
    """Density feedforward through the pump's lag: look-ahead (mm), dead-beat gain, flow."""

    lead_mm: float = 0.0
    gain: float = 1.0
    q_outer_ml_min: float = 0.3


GAINS: dict[str, type] = {"floor": FloorGains, "free": FreeGains, "buoyant": BuoyantGains}

#: the grids :func:`tune` searches (every combination), per family
GRIDS: dict[str, dict[str, Sequence[float]]] = {
    "floor": {
        "gain_1_s": (20.0, 40.0, 80.0, 160.0),
        "lead_mm": (-2.0, 0.0, 2.0, 5.0),
        "q_outer_ml_min": (0.35, 0.4, 0.45, 0.5),
        "runout": (0.0, 0.5, 1.0, 1.2),
    },
    "free": {
        "prefactor": (0.3, 0.35, 0.42, 0.5),
        "lead_mm": (0.0, 5.0, 10.0, 15.0),
        "integral_gain": (0.0, 0.05, 0.1, 0.2),
    },
    "buoyant": {
        "lead_mm": (0.0, 1.0, 2.0, 3.0, 5.0, 8.0),
        "gain": (0.5, 1.0, 2.0, 4.0),
        "q_outer_ml_min": (0.3, 0.4, 0.5),
    },
}


def controller_file() -> Path:
    from bathprint.agents.hyperparams import agents_dir

    return agents_dir() / "controller.yml"


def load_gains(family: str, path: Path | None = None) -> Any:
    """The tuned gains of ``family`` (``agents/controller.yml``), or the defaults if it has
    not been tuned."""
    import yaml

    if family not in GAINS:
        raise ConfigError(f"family = {family!r}; allowed: {', '.join(GAINS)}")
    p = path or controller_file()
    data = yaml.safe_load(p.read_text()) if p.is_file() else {}
    entry = (data or {}).get(family)
    cls = GAINS[family]
    if not entry:
        return cls()
    return cls(**{f.name: float(entry["gains"][f.name]) for f in dataclasses.fields(cls)})


# ------------------------------------------------------------------------------ policies
class _Controller:
    """What the three controllers share: the ``predict`` signature and the reset check."""

    def __init__(self, env: Any) -> None:
        u = env.unwrapped
        if getattr(u, "version", 0) < 1:
            raise ConfigError(f"controller needs a version-1 environment; got {u.env_id}")
        self.env = u
        self._target: Any = None

    def _new_episode(self) -> bool:
        u = self.env
        if u.steps_taken == 0 or u.target is not self._target:
            self._target = u.target
            return True
        return False

    def _target_index(self, lead_mm: float) -> int:
        """The target sample at arclength (printed so far past the lead-in) + lead_mm."""
        u = self.env
        s = (u.printed_mm - u.lead_in_mm + lead_mm) / u.target.spacing_mm
        return int(min(max(round(s), 0), u.target.n_samples - 1))

    def action(self, obs: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def predict(
        self,
        observation: Any,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]:
        obs = np.asarray(observation)
        if obs.ndim > 1:
            raise ValueError("controller drives one environment: give one observation")
        return self.action(obs), state


class FloorController(_Controller):
    """Needle tracking of the placed shape (module doc, floor)."""

    def __init__(self, env: Any, gains: FloorGains | None = None) -> None:
        super().__init__(env)
        u = self.env
        if not {"x", "y"} <= set(u.needle_axes):
            raise ConfigError(
                f"the floor controller moves the needle in x and y; {u.env_id} has needle "
                f"axes {u.needle_axes!r}"
            )
        self.gains = gains or FloorGains()
        self._path = np.zeros((1, 2))

    def action(self, obs: np.ndarray) -> np.ndarray:
        from bathprint.envs.shape_geometry import place_in_box

        u, g = self.env, self.gains
        if self._new_episode():
            if hasattr(u, "shape_target"):  # a shape environment placed the shape itself
                self._path = np.asarray(u.target.points_mm, float)[:, :2].copy()
            else:
                self._path = place_in_box(u.target.points_mm, u.needle_mm, u.needle_box_mm)
        qo = min(max(g.q_outer_ml_min, u.q_outer_range[0]), u.q_outer_range[1])
        a = u.controls_to_action(qo)
        path, h = self._path, u.target.spacing_mm
        s = (u.printed_mm - u.lead_in_mm + g.lead_mm) / h
        n = len(path)
        if s > n - 1 and g.runout > 0 and n >= 2:
            k = max(0, n - 1 - int(round(2.0 / h)))
            t = path[-1] - path[k]
            t = t / (np.linalg.norm(t) + 1e-12)
            aim = path[-1] + t * (s - (n - 1)) * h * g.runout
        else:
            aim = path[int(min(max(round(s), 0), n - 1))]
        v = g.gain_1_s * (aim - u.needle_mm[:2])  # mm/s
        for k, axis in enumerate("xy"):
            a[u.action_names.index(f"needle_v{axis}")] = v[k] / u.needle_speed_mm_s
        return np.clip(a, -1.0, 1.0).astype(np.float32)


class FreeController(_Controller):
    """The scaling-law feedforward with a tuned prefactor and look-ahead, and integral
    feedback on the printed curvature (module doc)."""

    #: the printed curvature fed back: the observation's, this far behind the tip (mm)
    FEEDBACK_MM = 4.0

    def __init__(self, env: Any, gains: FreeGains | None = None) -> None:
        from bathprint.agents.policies import FeedforwardPolicy

        super().__init__(env)
        self.gains = gains or FreeGains()
        self._law = FeedforwardPolicy(
            env, prefactor=self.gains.prefactor, lead_mm=self.gains.lead_mm
        )
        self._integral = 0.0

    def action(self, obs: np.ndarray) -> np.ndarray:
        from bathprint.envs.observation import CURV_OFFSETS_MM, OBS_CURVATURE_MM

        u, g = self.env, self.gains
        if self._new_episode():
            self._integral = 0.0
        ctl = self._law.controls(obs)
        if g.integral_gain > 0:
            col = CURV_OFFSETS_MM.index(self.FEEDBACK_MM)
            kappa = float(obs[u.obs_slices()["printed_curvature"]][col]) / OBS_CURVATURE_MM
            k = self._target_index(-self.FEEDBACK_MM)
            aim = float(u.target.curvature_1_mm[k])
            if kappa > 1e-3 and aim > 1e-3:
                # kappa ~ v^(1/3) on the scaling law: too curved -> slower
                step = -3.0 * g.integral_gain * math.log(kappa / aim)
                self._integral = min(max(self._integral + step, -2.0), 2.0)
        qo = ctl["q_outer_ml_min"] * math.exp(self._integral)
        qo = min(max(qo, u.q_outer_range[0]), u.q_outer_range[1])
        a = u.controls_to_action(qo, ctl["q_inner_ml_min"])
        return np.clip(a, -1.0, 1.0).astype(np.float32)


class BuoyantController(_Controller):
    """Density aim through the dead-beat inverse of the pump's lag (module doc)."""

    def __init__(self, env: Any, gains: BuoyantGains | None = None) -> None:
        from bathprint.agents.policies import LawConstants

        super().__init__(env)
        u = self.env
        if "q_inner" not in u.action_names:
            raise ConfigError(
                f"the buoyant controller sets the oil flow; {u.env_id} has no q_inner"
            )
        self.gains = gains or BuoyantGains()
        self.constants = LawConstants.from_env(env)

    def action(self, obs: np.ndarray) -> np.ndarray:
        from bathprint.envs.base import ML_MIN, MM

        u, g, c = self.env, self.gains, self.constants
        self._new_episode()
        tgt = u.target
        k = self._target_index(g.lead_mm)
        rho_aim = 0.5 * (tgt.density_lo_kg_m3[k] + tgt.density_hi_kg_m3[k])
        phi = 0.0
        if c.rho_gel > c.rho_inner:
            phi = (c.rho_gel - rho_aim) / (c.rho_gel - c.rho_inner)
        lo, hi = u.inner_fraction_range if u.inner_as_fraction else (0.0, c.phi_max)
        phi = min(max(phi, lo), min(hi, c.phi_max))
        qo = min(max(g.q_outer_ml_min, u.q_outer_range[0]), u.q_outer_range[1])
        q_aim = phi / (1.0 - phi) * qo
        q_now = u.inner_flow_now_ml_min
        q_cmd = q_aim
        if u.inner_lag_s > 0:
            dt = u.control_length_mm * MM * u.needle_area / ((qo + q_aim) * ML_MIN)
            keep = math.exp(-dt / u.inner_lag_s)
            q_cmd = q_now + g.gain * (q_aim - q_now) / (1.0 - keep)
        q_cmd = max(q_cmd, 0.0)
        a = u.controls_to_action(qo, q_cmd)
        return np.clip(a, -1.0, 1.0).astype(np.float32)


CONTROLLERS: dict[str, type] = {
    "floor": FloorController,
    "free": FreeController,
    "buoyant": BuoyantController,
}


def make_controller(env: Any, family: str | None = None, gains: Any = None) -> _Controller:
    """The controller of ``family`` (default: the environment's,
    :func:`~bathprint.envs.shape_files.env_family`) with ``gains`` (default: the tuned
    ones)."""
    from bathprint.envs.shape_files import env_family

    fam = family or env_family(env)
    if fam not in CONTROLLERS:
        raise ConfigError(f"family = {fam!r}; allowed: {', '.join(CONTROLLERS)}")
    return CONTROLLERS[fam](env, gains if gains is not None else load_gains(fam))


# ------------------------------------------------------------------------------ scoring
def score_shapes(
    env: Any,
    policy: Any,
    family: str,
    shapes: Sequence[tuple[str, np.ndarray]],
    seed: int = 0,
) -> list[dict[str, Any]]:
    """One deterministic episode per named shape; the whole-shape error of each (RMS and
    maximum mm; NaN where the episode was cut short) and the local metric M (``metric``)."""
    from bathprint.agents.rollout import run_episode
    from bathprint.envs.shape_files import place_shape, reference_curve, written_curve
    from bathprint.envs.shape_metric import shape_error

    rows = []
    for name, pts in shapes:
        target = place_shape(pts, env, family, name)
        ep = run_episode(env, policy, seed, options={"target": target})
        written = written_curve(env, family)
        ok = not ep.truncated and len(written) == target.n_samples
        err = shape_error(written, reference_curve(pts, env, family), family) if ok else None
        rows.append(
            {
                "shape": name,
                "rms_mm": err.rms_mm if err else math.nan,
                "max_mm": err.max_mm if err else math.nan,
                "success": bool(err and err.success),
                # the local metric M (a shape environment's own metric is the rms above)
                "metric": float(ep.metrics.get("local_metric", ep.metrics["metric"])),
                "truncated": bool(ep.truncated),
            }
        )
    return rows


def tune(
    family: str,
    accuracy: str = "draft",
    grid: dict[str, Sequence[float]] | None = None,
    path: Path | None = None,
    progress: bool = True,
) -> dict[str, Any]:
    """Grid search of a family's gains on its *validation* shapes (writable ones): the
    gains with the smallest mean RMS error (mm) win. Writes the family's entry of
    ``agents/controller.yml`` (gains, score, every grid point's score) and returns it."""
    import yaml
    from tqdm import tqdm

    from bathprint.envs import make

    if family not in GAINS:
        raise ConfigError(f"family = {family!r}; allowed: {', '.join(GAINS)}")
    grid = grid or GRIDS[family]
    cls = GAINS[family]
    env = make(FAMILY_ENVS[family], accuracy=accuracy)
    shapes = family_shapes(family, "validation", writable_only=True)
    names = list(grid)
    points = list(itertools.product(*(grid[n] for n in names)))
    scores = []
    for values in tqdm(points, desc=f"tune controller {family}", disable=not progress):
        gains = cls(**dict(zip(names, map(float, values), strict=True)))
        rows = score_shapes(env, CONTROLLERS[family](env, gains), family, shapes)
        rms = [r["rms_mm"] for r in rows]
        mean = float(np.mean(rms)) if all(map(math.isfinite, rms)) else math.inf
        scores.append(
            {
                **{n: float(v) for n, v in zip(names, values, strict=True)},
                "mean_rms_mm": round(mean, 4),
                "successes": int(sum(r["success"] for r in rows)),
            }
        )
    env.close()
    best = min(range(len(points)), key=lambda i: (scores[i]["mean_rms_mm"], i))
    chosen = dataclasses.asdict(cls(**dict(zip(names, map(float, points[best]), strict=True))))
    entry = {
        "env_id": FAMILY_ENVS[family],
        "accuracy": accuracy,
        "validation_shapes": [n for n, _ in shapes],
        "gains": chosen,
        "mean_rms_mm": scores[best]["mean_rms_mm"],
        "successes": scores[best]["successes"],
        "grid": scores,
    }
    p = path or controller_file()
    data = yaml.safe_load(p.read_text()) if p.is_file() else {}
    data = data or {}
    data[family] = entry
    header = (
        "# The shape controllers' gains (bathprint.agents.controller), tuned on each family's\n"
        "# validation shapes by `python -m bathprint.agents.controller tune --family F`.\n"
    )
    p.write_text(header + yaml.safe_dump(data, sort_keys=True))
    return entry


def main(argv: Sequence[str] | None = None) -> int:
    import argparse

    ap = argparse.ArgumentParser(prog="python -m bathprint.agents.controller")
    sub = ap.add_subparsers(dest="command", required=True)
    t = sub.add_parser("tune", help="tune a family's gains on its validation shapes")
    t.add_argument("--family", choices=list(GAINS), action="append")
    t.add_argument("--accuracy", default="draft")
    args = ap.parse_args(argv)
    for fam in args.family or list(GAINS):
        entry = tune(fam, args.accuracy)
        print(
            f"{fam}: {entry['gains']}  mean RMS {entry['mean_rms_mm']:.3f} mm, "
            f"{entry['successes']}/{len(entry['validation_shapes'])} written"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
