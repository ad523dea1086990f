"""Targets printed by the environment itself: reachable by construction.

A printed target is the filament that a version-1 environment prints when it replays a random
smooth control sequence from one of its warm-up states. Replaying that sequence (the
target's :attr:`~bathprint.envs.targets.Target.actions`) from the same start state at the
target's ``print_accuracy`` prints the same filament, so the attainable error of every
printed target is 0 there (and the model difference at another preset).

A target is identified by a seed. Three disjoint seed ranges give the target sets:

==============  ==========================  ==============================================
set             seeds                       use
==============  ==========================  ==============================================
``train``       0 .. train_pool - 1         training (drawn from the env's ``np_random``)
``validation``  2 000 000 + k, k < size     model selection, early stopping, tuning
``test``        1 000 000 + k, k < size     reported numbers only
==============  ==========================  ==============================================

From the seed come the start state and the control sequence, one generator per action
component (``[target.params.<action>]`` of the spec):

- ``kind = "sections"``: ``sections = [min, max]`` equal sections of the target's length,
  each a constant level drawn uniformly from ``range`` (action units), joined by linear ramps
  of ``ramp_mm``; the lead-in holds the first level, the settling length the last.
- ``kind = "knots"``: a value drawn from ``range`` every ``every_mm`` of printed length,
  linear in between (smooth needle paths). For needle velocities a knot whose path would
  leave 80 % of the needle box is mirrored, so that paths stay mostly inside it.

Action components without a generator stay at 0 (mid-range; a needle velocity of 0).

The validation and test targets of the shipped specs are data: ``envs/<sets_file>``
(written by ``python -m bathprint.envs.printed build ENV``), used whenever its generator hash
matches the spec's, so the sets stay fixed when the simulator changes. Training targets (and
sets whose file does not match) are printed on first use: kept in memory, and on disk under
``$BATHPRINT_CACHE_DIR`` (default ``~/.cache/bathprint``; empty: no disk cache) keyed by
the spec and the simulator's kernel sources. A target costs one episode at the print preset.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from bathprint.envs.targets import (
    FREE_DENSITY,
    Target,
    discrete_curvature,
    discrete_torsion,
)
from bathprint.errors import ConfigError

if TYPE_CHECKING:
    from bathprint.envs.v1 import BathprintEnvV1

TEST_SEED0 = 1_000_000
VALIDATION_SEED0 = 2_000_000
MAX_ATTEMPTS = 5  # a control sequence whose print diverges is drawn again (attempt + 1)
SET_NAMES = ("train", "validation", "test")
GENERATOR_KINDS = ("sections", "knots")

# printed targets by (generator hash, seed); printers by generator hash (one per process)
_TARGETS: dict[tuple[str, int], Target] = {}
_PRINTERS: dict[str, Any] = {}
_SHIPPED: dict[str, dict[int, Target] | None] = {}


# ------------------------------------------------------------------------------ generators
def check_generators(params: dict[str, Any], action_names: Sequence[str], where: str) -> None:
    """``[target.params]`` of a printed family: one table per action component."""
    for name, gen in params.items():
        if name not in action_names:
            raise ConfigError(
                f"{where}: target.params.{name}: not an action of this environment; allowed: "
                + ", ".join(action_names)
            )
        if not isinstance(gen, dict) or gen.get("kind") not in GENERATOR_KINDS:
            raise ConfigError(
                f"{where}: target.params.{name} = {gen!r}; allowed: a table with kind = "
                + " or ".join(repr(k) for k in GENERATOR_KINDS)
            )
        allowed = {"kind", "range"} | (
            {"sections", "ramp_mm"} if gen["kind"] == "sections" else {"every_mm"}
        )
        for key in gen:
            if key not in allowed:
                raise ConfigError(
                    f"{where}: target.params.{name}.{key}: unknown; allowed: "
                    + ", ".join(sorted(allowed))
                )
        rng = gen.get("range", [-1.0, 1.0])
        if not (
            isinstance(rng, list | tuple)
            and len(rng) == 2
            and all(isinstance(x, int | float) and not isinstance(x, bool) for x in rng)
            and -1.0 <= rng[0] <= rng[1] <= 1.0
        ):
            raise ConfigError(
                f"{where}: target.params.{name}.range = {rng!r}; allowed: [low, high] with "
                "-1 <= low <= high <= 1 (action units)"
            )
        if gen["kind"] == "sections":
            sec = gen.get("sections", [1, 1])
            if not (
                isinstance(sec, list | tuple)
                and len(sec) == 2
                and all(isinstance(x, int) and not isinstance(x, bool) for x in sec)
                and 1 <= sec[0] <= sec[1]
            ):
                raise ConfigError(
                    f"{where}: target.params.{name}.sections = {sec!r}; allowed: [min, max] "
                    "integers with 1 <= min <= max"
                )
            ramp = gen.get("ramp_mm", 0.0)
            if not (isinstance(ramp, int | float) and not isinstance(ramp, bool) and ramp >= 0):
                raise ConfigError(
                    f"{where}: target.params.{name}.ramp_mm = {ramp!r}; allowed: a number >= 0"
                )
        else:
            every = gen.get("every_mm", 10.0)
            if not (isinstance(every, int | float) and not isinstance(every, bool) and every > 0):
                raise ConfigError(
                    f"{where}: target.params.{name}.every_mm = {every!r}; allowed: a number > 0"
                )


def _sections(
    gen: dict[str, Any], s_mid: np.ndarray, lead: float, length: float, rng: np.random.Generator
) -> np.ndarray:
    lo, hi = (float(x) for x in gen.get("range", [-1.0, 1.0]))
    n_lo, n_hi = (int(x) for x in gen.get("sections", [1, 1]))
    n = int(rng.integers(n_lo, n_hi + 1))
    levels = rng.uniform(lo, hi, n)
    edges = lead + np.linspace(0.0, length, n + 1)
    half = min(0.5 * float(gen.get("ramp_mm", 0.0)), 0.25 * length / n)
    knots_s, knots_v = [edges[0]], [levels[0]]
    for k in range(1, n):
        if half > 0:
            knots_s += [edges[k] - half, edges[k] + half]
            knots_v += [levels[k - 1], levels[k]]
        else:  # a step: the level changes at the edge
            knots_s += [edges[k] - 1e-9, edges[k]]
            knots_v += [levels[k - 1], levels[k]]
    knots_s.append(edges[-1])
    knots_v.append(levels[-1])
    return np.interp(s_mid, knots_s, knots_v)


def _knots(
    gen: dict[str, Any], s_mid: np.ndarray, total: float, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = (float(x) for x in gen.get("range", [-1.0, 1.0]))
    every = float(gen.get("every_mm", 10.0))
    knot_s = np.arange(int(math.ceil(total / every)) + 1) * every
    return knot_s, rng.uniform(lo, hi, len(knot_s))


def control_sequence(env: BathprintEnvV1, rng: np.random.Generator) -> np.ndarray:
    """A random smooth control sequence for a whole episode of ``env``'s default layout:
    (steps, actions) float32 in action units (see the module doc)."""
    gens = env.spec_data.target.get("params", {})
    names = env.action_names
    n_steps = env.steps_for_length(env.target_length_mm)
    step = env.control_length_mm
    s_mid = (np.arange(n_steps) + 0.5) * step  # printed length at the middle of each step
    total = n_steps * step
    out = np.zeros((n_steps, len(names)))
    knot_axes: list[tuple[int, np.ndarray, np.ndarray]] = []
    for k, name in enumerate(names):
        gen = gens.get(name)
        if gen is None:
            continue
        if gen["kind"] == "sections":
            out[:, k] = _sections(gen, s_mid, env.lead_in_mm, env.target_length_mm, rng)
        else:
            knot_s, values = _knots(gen, s_mid, total, rng)
            knot_axes.append((k, knot_s, values))
            out[:, k] = np.interp(s_mid, knot_s, values)
    needle = [(k, ks, v) for k, ks, v in knot_axes if names[k].startswith("needle_v")]
    if needle:
        _keep_needle_in_box(env, out, needle, s_mid)
    return np.clip(out, -1.0, 1.0).astype(np.float32)


def _keep_needle_in_box(
    env: BathprintEnvV1,
    out: np.ndarray,
    axes: list[tuple[int, np.ndarray, np.ndarray]],
    s_mid: np.ndarray,
) -> None:
    """Mirror needle-velocity knots whose path would leave 80 % of the box (kinematics of the
    flow sequence, lag and ramps ignored: a heuristic; the environment clips anyway)."""
    dt = np.array([env.step_duration_s(a) for a in out])
    for k, knot_s, values in axes:
        axis = "xyz".index(env.action_names[k][-1])
        lo, hi = env.needle_box_mm[axis]
        centre, half = 0.5 * (lo + hi), 0.4 * (hi - lo)
        v = values.copy()
        for _ in range(len(v)):
            vel = np.interp(s_mid, knot_s, v) * env.needle_speed_mm_s
            pos = env.needle_start_mm[axis] + np.cumsum(vel * dt)
            bad = np.nonzero(np.abs(pos - centre) > half)[0]
            if not len(bad):
                break
            j = int(np.searchsorted(knot_s, s_mid[bad[0]]))  # first knot after the exit
            side = np.sign(pos[bad[0]] - centre)
            j0 = max(j - 1, 0)
            v[j0:] = np.where(np.sign(v[j0:]) == side, -v[j0:], v[j0:])
        out[:, k] = np.interp(s_mid, knot_s, v)


# ------------------------------------------------------------------------------ the family
def cache_root() -> Path | None:
    """``$BATHPRINT_CACHE_DIR`` (empty: no disk cache), else ``~/.cache/bathprint``."""
    value = os.environ.get("BATHPRINT_CACHE_DIR")
    if value is not None:
        return Path(value) if value else None
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "bathprint"


class PrintedTargets:
    """The printed target family of one environment (spec): seeds, printing, caches."""

    def __init__(self, env: BathprintEnvV1) -> None:
        sd = env.spec_data
        tg = sd.target
        self.env_cls = type(env)
        self.env_id = env.env_id
        self.spec_file = env.spec_file
        self.spec_overrides = env.spec_overrides_given
        self.print_accuracy = str(tg.get("print_accuracy", "draft"))
        self.train_pool = int(tg.get("train_pool", 1024))
        self.sizes = {
            "validation": int(tg.get("validation_size", 16)),
            "test": int(tg.get("test_size", 16)),
        }
        self.sets_file = str(tg.get("sets_file", ""))
        self.w_density = float(sd.metric.get("w_density", 0.0))
        self.band = float(tg.get("band_kg_m3", 0.0))
        check_generators(tg.get("params", {}), env.default_action_names, sd.path)
        described = sd.to_dict()
        for key in ("train_pool", "validation_size", "test_size", "sets_file"):
            described["target"].pop(key, None)
        for key in ("summary", "entry_point", "success", "observation"):
            described.pop(key, None)
        text = json.dumps(described, sort_keys=True, separators=(",", ":"), default=str)
        #: identifies what prints the targets (not the simulator's code: see disk_dir)
        self.generator_hash = hashlib.sha1(text.encode()).hexdigest()[:16]
        self.key_of_seed: dict[int, str] = {}

    # ---------------------------------------------------------------- sets
    def seeds(self, target_set: str) -> list[int]:
        """Seeds of the fixed validation or test set (in index order)."""
        if target_set == "test":
            return [TEST_SEED0 + k for k in range(self.sizes["test"])]
        if target_set == "validation":
            return [VALIDATION_SEED0 + k for k in range(self.sizes["validation"])]
        raise ConfigError(f"target_set = {target_set!r}: only validation and test are fixed")

    def train_seed(self, rng: np.random.Generator) -> int:
        return int(rng.integers(self.train_pool))

    def set_of_seed(self, seed: int) -> str:
        if seed >= VALIDATION_SEED0:
            return "validation"
        return "test" if seed >= TEST_SEED0 else "train"

    def params(self, seed: int, attempt: int = 0, start_state: int | None = None) -> dict:
        p: dict[str, Any] = {
            "family": "printed",
            "env": self.env_id,
            "generator": self.generator_hash,
            "seed": int(seed),
            "attempt": int(attempt),
        }
        if start_state is not None:
            p["start_state"] = int(start_state)
        return p

    # ---------------------------------------------------------------- targets
    def get(self, seed: int) -> Target:
        """The printed target of ``seed``: memory, the shipped sets file, disk, or printed."""
        key = (self.generator_hash, int(seed))
        if key not in _TARGETS:
            target = self._shipped().get(int(seed)) if self.set_of_seed(seed) != "train" else None
            if target is None:
                target = self._from_disk(seed)
            if target is None:
                target = self.print(seed)
                self._to_disk(seed, target)
            _TARGETS[key] = target
        return _TARGETS[key]

    def printer(self) -> BathprintEnvV1:
        """The environment that prints the targets (the spec's default controls at
        ``print_accuracy``; one per process and generator)."""
        if self.generator_hash not in _PRINTERS:
            _PRINTERS[self.generator_hash] = self.env_cls(
                accuracy=self.print_accuracy,
                spec_file=self.spec_file,
                spec_overrides=self.spec_overrides,
                _printer=True,
            )
        return _PRINTERS[self.generator_hash]

    def draw(self, seed: int, attempt: int = 0) -> tuple[dict, np.ndarray]:
        """The parameters (start state included) and the control sequence of a seed."""
        env = self.printer()
        rng = np.random.default_rng([int(seed), int(attempt)])
        start = int(rng.integers(env.n_start_states))
        return self.params(seed, attempt, start), control_sequence(env, rng)

    def print(self, seed: int) -> Target:
        """Print the target of ``seed`` (a control sequence that diverges is drawn again)."""
        env = self.printer()
        for attempt in range(MAX_ATTEMPTS):
            params, actions = self.draw(seed, attempt)
            start = params["start_state"]
            env.reset(seed=0, options={"target": env.blank_target(), "start_state": start})
            ok = True
            for a in actions:
                _, _, term, trunc, _ = env.step(a)
                if trunc:
                    ok = False
                    break
            if ok and term:
                pts, rho = env.recorded_samples()
                return self.build(params, pts, rho, actions)
        raise RuntimeError(
            f"{self.env_id}: the target of seed {seed} diverged in {MAX_ATTEMPTS} attempts"
        )

    def build(self, params: dict, pts: np.ndarray, rho: np.ndarray, actions: np.ndarray) -> Target:
        """A target from printed samples: the centreline, its curvature and torsion, and a
        density band (the printed density +- band_kg_m3 where the metric scores density)."""
        env = self.printer()
        h = env.target_spacing_mm
        k = max(1, int(round(1.0 / h)))
        pts = np.ascontiguousarray(pts, np.float64)
        if self.w_density > 0:
            settled = rho if env.bath_range is None else np.clip(rho, *env.bath_range)
            lo, hi = settled - self.band, settled + self.band
        else:
            lo, hi = np.full(len(pts), FREE_DENSITY[0]), np.full(len(pts), FREE_DENSITY[1])
        target = Target(
            name=f"printed:{params['seed']}",
            params=params,
            spacing_mm=h,
            points_mm=pts,
            curvature_1_mm=discrete_curvature(pts, k),
            torsion_1_mm=discrete_torsion(pts, 2 * k),
            density_lo_kg_m3=np.asarray(lo, np.float64),
            density_hi_kg_m3=np.asarray(hi, np.float64),
            actions=np.asarray(actions, np.float32),
        )
        self.key_of_seed[int(params["seed"])] = target.key
        return target

    # ---------------------------------------------------------------- files
    def sets_path(self) -> Path | None:
        if not self.sets_file:
            return None
        from bathprint.envs.spec import specs_dir

        return specs_dir() / self.sets_file

    def _shipped(self) -> dict[int, Target]:
        """The validation and test targets of the sets file, if it matches this spec."""
        if self.generator_hash not in _SHIPPED:
            found: dict[int, Target] | None = None
            path = self.sets_path()
            if path is not None and path.is_file():
                with np.load(path) as d:
                    meta = json.loads(str(d["meta"]))
                    if meta.get("generator") == self.generator_hash:
                        found = {}
                        for i, p in enumerate(json.loads(str(d["params"]))):
                            found[int(p["seed"])] = self.build(
                                p, d["points"][i], d["density"][i], d["actions"][i]
                            )
            _SHIPPED[self.generator_hash] = found
        return _SHIPPED[self.generator_hash] or {}

    def uses_sets_file(self) -> bool:
        """Whether the validation and test targets come from the shipped file."""
        return bool(self._shipped())

    def write_sets_file(self, path: Path | None = None, progress: bool = True) -> Path:
        """Print the validation and test targets and store them (``build`` command)."""
        from tqdm import tqdm

        path = path or self.sets_path()
        if path is None:
            raise ConfigError(f"{self.env_id}: target.sets_file is not set")
        seeds = self.seeds("validation") + self.seeds("test")
        targets = [
            self.print(s) for s in tqdm(seeds, desc=f"print {self.env_id}", disable=not progress)
        ]
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(
            path,
            meta=json.dumps({"generator": self.generator_hash, "env": self.env_id}),
            params=json.dumps([t.params for t in targets]),
            points=np.stack([t.points_mm for t in targets]),
            density=np.stack([self._density_of(t) for t in targets]),
            actions=np.stack([t.actions for t in targets]),
        )
        _SHIPPED.pop(self.generator_hash, None)
        return path

    def _density_of(self, t: Target) -> np.ndarray:
        # the band's centre is the printed (settled) density; without density, the gel's
        if self.w_density > 0:
            return 0.5 * (t.density_lo_kg_m3 + t.density_hi_kg_m3)
        return np.full(t.n_samples, self.printer().rho_gel)

    def disk_dir(self) -> Path | None:
        root = cache_root()
        if root is None:
            return None
        from bathprint._cache import _sources_hash

        sim = _sources_hash()[:12]
        return root / "printed" / f"{self.generator_hash}-{sim}"

    def _from_disk(self, seed: int) -> Target | None:
        d = self.disk_dir()
        path = d / f"{int(seed)}.npz" if d is not None else None
        if path is None or not path.is_file():
            return None
        try:
            with np.load(path) as f:
                params = json.loads(str(f["params"]))
                return self.build(params, f["points"], f["density"], f["actions"])
        except (OSError, ValueError, KeyError):
            return None  # a damaged file: print again

    def _to_disk(self, seed: int, target: Target) -> None:
        d = self.disk_dir()
        if d is None:
            return
        try:
            d.mkdir(parents=True, exist_ok=True)
            tmp = d / f".{int(seed)}.{os.getpid()}.npz"
            np.savez(
                tmp,
                params=json.dumps(target.params),
                points=target.points_mm,
                density=self._density_of(target),
                actions=target.actions,
            )
            tmp.replace(d / f"{int(seed)}.npz")
        except OSError:
            pass  # a read-only cache: print again next time


def set_keys(env: BathprintEnvV1, target_set: str) -> list[str]:
    """Keys of the targets of a set (the whole pool for ``train``: prints them)."""
    fam = env.printed
    seeds = range(fam.train_pool) if target_set == "train" else fam.seeds(target_set)
    return [fam.get(s).key for s in seeds]


# ------------------------------------------------------------------------------ command
def main(argv: Sequence[str] | None = None) -> int:
    """``python -m bathprint.envs.printed build ENV [ENV ...]``: print the validation and
    test targets of each version-1 environment into its sets file;
    ``... train ENV --count N``: print (and cache on disk) the first N training targets."""
    ap = argparse.ArgumentParser(
        prog="python -m bathprint.envs.printed",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("action", choices=("build", "train"))
    ap.add_argument("envs", nargs="+")
    ap.add_argument("--count", type=int, default=None, help="training targets (train)")
    ap.add_argument("--quiet", action="store_true")
    args = ap.parse_args(argv)
    import bathprint.envs as E

    for name in args.envs:
        try:
            env = E.make(name).unwrapped
        except ValueError as exc:
            print(f"bathprint.envs.printed: {exc}", file=sys.stderr)
            return 2
        fam = getattr(env, "printed", None)
        if fam is None:
            print(f"bathprint.envs.printed: {name} has no printed targets", file=sys.stderr)
            return 2
        if args.action == "build":
            print(f"wrote {fam.write_sets_file(progress=not args.quiet)}")
        else:
            from tqdm import tqdm

            n = fam.train_pool if args.count is None else min(args.count, fam.train_pool)
            for s in tqdm(range(n), desc=f"train targets {env.env_id}", disable=args.quiet):
                fam.get(s)
            print(f"{env.env_id}: {n} training targets in {fam.disk_dir()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
