"""Record (``--write``) or replay hashes of everything an environment returns: per step the
observation (flat or goal form), reward, flags and the whole ``info`` dict, plus what the
public methods give (controls, goals, rewards of goals, states, a rendered frame, a printed
target), for every registered id and the paths the pinned episodes
(``pinned_episodes.py``) do not take: needle velocities, goal-conditioned observations,
fixed-set cycling, options, a diverged episode, state cloning.

    python tests/data/pinned_infos.py            # replay: identical?
    python tests/data/pinned_infos.py --write    # rewrite tests/data/pinned_infos.json

Re-record only when a version's results change on purpose (and say so in the commit).
"""

from __future__ import annotations

import argparse
import hashlib
import json
from pathlib import Path
from typing import Any

import numpy as np

PATH = Path(__file__).with_name("pinned_infos.json")

V0_IDS = ("bathprint/CoilRadius-v0", "bathprint/WriteShape-v0", "bathprint/BuoyantLayers-v0")
V1_IDS = (
    "bathprint/CoilRadius-v1",
    "bathprint/WriteShape-v1",
    "bathprint/BuoyantLayers-v1",
    "bathprint/WriteShape-v2",
)
SHAPE_IDS = ("bathprint/WriteShape-v3", "bathprint/CoilRadius-v2", "bathprint/BuoyantLayers-v2")


def _canon(x: Any) -> Any:
    """A JSON-able, exact form of a value (floats as hex, arrays as dtype/shape/bytes)."""
    if isinstance(x, dict):
        return {str(k): _canon(v) for k, v in sorted(x.items(), key=lambda kv: str(kv[0]))}
    if isinstance(x, list | tuple):
        return [_canon(v) for v in x]
    if isinstance(x, np.ndarray):
        a = np.ascontiguousarray(x)
        return ["nd", str(a.dtype), list(a.shape), hashlib.sha256(a.tobytes()).hexdigest()]
    if isinstance(x, bool | np.bool_):
        return ["b", bool(x)]
    if isinstance(x, np.floating):
        return ["npf", str(x.dtype), float(x).hex()]
    if isinstance(x, float):
        return ["f", x.hex()]
    if isinstance(x, int | np.integer):
        return ["i", int(x)]
    if x is None or isinstance(x, str):
        return x
    return ["repr", type(x).__name__, repr(x)]


class Log:
    """Named streams of canonical values, hashed at the end."""

    def __init__(self) -> None:
        self.streams: dict[str, list[Any]] = {}

    def add(self, stream: str, value: Any) -> None:
        self.streams.setdefault(stream, []).append(_canon(value))

    def hashes(self) -> dict[str, str]:
        return {
            k: hashlib.sha256(json.dumps(v, sort_keys=True).encode()).hexdigest()
            for k, v in sorted(self.streams.items())
        }


def _step_log(log: Log, out: tuple) -> None:
    obs, reward, terminated, truncated, info = out
    log.add("obs", obs)
    log.add("reward", reward)
    log.add("flags", (terminated, truncated))
    log.add("info", info)


def _actions(env: Any, seed: int, n: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [rng.uniform(-1.0, 1.0, env.action_space.shape).astype(np.float32) for _ in range(n)]


def _spaces(log: Log, u: Any) -> None:
    log.add("spaces", (repr(u.observation_space), repr(u.action_space), list(u.action_names)))


def case_v0(env_id: str) -> dict[str, str]:
    import bathprint.envs as E

    log = Log()
    env = E.make(env_id, accuracy="draft", needle_velocity=True)
    u = env.unwrapped
    _spaces(log, u)
    obs, info = env.reset(seed=11)
    log.add("reset", (obs, info))
    for a in _actions(env, 21, 25):
        log.add("controls", u.action_to_controls(a))
        _step_log(log, env.step(a))
    log.add("controls_to_action", u.controls_to_action(0.7, 0.05))
    p = u.printed_samples()
    log.add("printed_samples", (p.points_mm, p.density_kg_m3))
    log.add("episode", (u.episode_length_mm, u.episode_steps))
    env.close()

    env = E.make(env_id, accuracy="draft", target_set="eval")
    for k in range(3):  # cycling through the eval set from a seeded reset
        obs, info = env.reset(seed=3 if k == 0 else None)
        log.add("eval_reset", (obs, info))
        for a in _actions(env, 30 + k, 3):
            _step_log(log, env.step(a))
    obs, info = env.reset(options={"target": env.unwrapped.sampler.eval_target(5)})
    log.add("option_target", (obs, info))
    env.close()

    env = E.make(env_id, accuracy="draft", spec_overrides={"episode": {"max_substeps": 1}})
    log.add("diverged_reset", env.reset(seed=0))
    for a in _actions(env, 40, 3):
        _step_log(log, env.step(a))
    env.close()
    return log.hashes()


def case_v1(env_id: str) -> dict[str, str]:
    import bathprint.envs as E

    log = Log()
    env = E.make(env_id, accuracy="draft", target_set="test")
    u = env.unwrapped
    _spaces(log, u)
    log.add("layout", (u.obs_layout, sorted(u.obs_slices().items(), key=str)))
    obs, info = env.reset(seed=2, options={"target_index": 4})
    log.add("reset", (obs, info))
    actions = _actions(env, 5, 200)
    for k, a in enumerate(actions):
        log.add("controls", u.action_to_controls(a))
        log.add("duration", u.step_duration_s(a))
        out = env.step(a)
        _step_log(log, out)
        if k % 10 == 0:
            log.add("ahead", u.target_ahead(out[0], 10.0))
        if out[2] or out[3]:
            break
    log.add("recorded", u.recorded_samples())
    p = u.printed_samples()
    log.add("printed_samples", (p.points_mm, p.density_kg_m3))
    log.add("actions_for", u.actions_for(u.target))
    log.add("controls_to_action", u.controls_to_action(0.7, 0.05))
    log.add("steps_for_length", u.steps_for_length(40.0))
    log.add("blank", u.blank_target().points_mm)
    env.close()

    # cycling, an option target, a training draw
    env = E.make(env_id, accuracy="draft", target_set="validation")
    for k in range(2):
        log.add("cycle", env.reset(seed=1 if k == 0 else None))
    t = env.unwrapped.fixed_set_target("test", 1)
    log.add("option_target", env.reset(options={"target": t, "start_state": 0}))
    env.close()
    env = E.make(env_id, accuracy="draft")
    log.add("train_reset", env.reset(seed=7))
    env.close()

    # the goal form with every needle axis; the rewards of goals; state cloning
    env = E.make(env_id, accuracy="draft", target_set="test", goal_conditioned=True,
                 needle_velocity=True)  # fmt: skip
    u = env.unwrapped
    _spaces(log, u)
    obs, info = env.reset(seed=4, options={"target_index": 2})
    log.add("goal_reset", (obs, info))
    achieved, desired = [], []
    acts = _actions(env, 6, 16)
    state = None
    for k, a in enumerate(acts):
        out = env.step(a)
        _step_log(log, out)
        achieved.append(out[0]["achieved_goal"])
        desired.append(out[0]["desired_goal"])
        if k == 7:
            state = u.get_state()
    ag, dg = np.array(achieved), np.array(desired)
    log.add("goal_reward", u.compute_reward(ag, dg[::-1].copy(), None))
    log.add("goal_reward_ref", u._goal_reward_one_by_one(ag, dg[::-1].copy()))
    assert state is not None
    env2 = E.make(env_id, accuracy="draft", target_set="test", goal_conditioned=True,
                  needle_velocity=True)  # fmt: skip
    env2.reset(seed=0)
    env2.unwrapped.set_state(state)
    for a in acts[8:]:
        _step_log(log, env2.step(a))
    env.close()
    env2.close()

    env = E.make(env_id, accuracy="draft", target_set="test")
    log.add("diverged_reset", env.reset(seed=0))
    env.unwrapped.max_substeps = 1  # (a spec override would change the targets' generator)
    for a in _actions(env, 40, 3):
        _step_log(log, env.step(a))
    env.close()
    return log.hashes()


def case_shape(env_id: str) -> dict[str, str]:
    """A shape environment: a test shape under random actions (info, rewards, the written
    and reference curves), a training draw from the generator, the held-out kinds cycled,
    state cloning and a diverged episode."""
    import bathprint.envs as E

    log = Log()
    env = E.make(env_id, accuracy="draft", target_set="test")
    u = env.unwrapped
    _spaces(log, u)
    log.add("layout", (u.obs_layout, sorted(u.obs_slices().items(), key=str)))
    obs, info = env.reset(seed=2, options={"target_index": 2})
    log.add("reset", (obs, info))
    state = None
    acts = _actions(env, 5, 200)
    for k, a in enumerate(acts):
        out = env.step(a)
        _step_log(log, out)
        if k == 9:
            state = u.get_state()
        if out[2] or out[3]:
            break
    log.add("written", (u.written_curve(), u.target.points_mm))
    assert state is not None
    env2 = E.make(env_id, accuracy="draft", target_set="test")
    env2.reset(seed=0)
    env2.unwrapped.set_state(state)
    for a in acts[10:30]:
        _step_log(log, env2.step(a))
    env.close()
    env2.close()

    env = E.make(env_id, accuracy="draft")
    log.add("train_reset", env.reset(seed=7))
    env.close()
    env = E.make(env_id, accuracy="draft", target_set="ood_test")
    for k in range(2):
        log.add("cycle", env.reset(seed=1 if k == 0 else None))
    env.unwrapped.max_substeps = 1
    for a in _actions(env, 40, 3):
        _step_log(log, env.step(a))
    env.close()
    return log.hashes()


def case_render() -> dict[str, str]:
    import bathprint.envs as E

    log = Log()
    for env_id in ("bathprint/CoilRadius-v0", "bathprint/WriteShape-v2"):
        env = E.make(env_id, accuracy="draft", render_mode="rgb_array")
        env.reset(seed=0)
        for a in _actions(env, 1, 5):
            env.step(a)
        log.add("frame", env.render())
        env.close()
    return log.hashes()


def case_print() -> dict[str, str]:
    """A training target printed afresh (not from a cache), and the printer's controls."""
    import bathprint.envs as E
    from bathprint.envs import printed

    log = Log()
    env = E.make("bathprint/WriteShape-v2", accuracy="draft")
    pt = env.unwrapped.printed
    params, seq = pt.draw(3)
    log.add("draw", (params, seq))
    t = pt.print(3)
    log.add("target", (t.points_mm, t.curvature_1_mm, t.torsion_1_mm, t.actions, t.params))
    log.add("keys", printed.set_keys(env.unwrapped, "test")[:3])
    env.close()
    return log.hashes()


def _import_all() -> None:
    """Import every environment module up front (a recording reads no file edited later)."""
    import importlib
    import pkgutil

    import bathprint.envs

    for mod in pkgutil.iter_modules(bathprint.envs.__path__):
        importlib.import_module(f"bathprint.envs.{mod.name}")


CASES = {
    **{f"v0:{i}": (case_v0, i) for i in V0_IDS},
    **{f"v1:{i}": (case_v1, i) for i in V1_IDS},
    **{f"shape:{i}": (case_shape, i) for i in SHAPE_IDS},
    "render": (case_render, None),
    "print": (case_print, None),
}


def run(name: str) -> dict[str, str]:
    fn, arg = CASES[name]
    return fn(arg) if arg is not None else fn()


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--write", action="store_true", help="re-record every case")
    ap.add_argument("cases", nargs="*", default=list(CASES))
    args = ap.parse_args()
    _import_all()
    ref = json.loads(PATH.read_text()) if PATH.is_file() else {}
    for name in args.cases:
        got = run(name)
        if args.write:
            ref[name] = got
            print(f"{name}: recorded")
        else:
            bad = [k for k in got if ref.get(name, {}).get(k) != got[k]]
            print(f"{name}: " + ("identical" if not bad else f"differ: {bad}"), flush=True)
    if args.write:
        PATH.write_text(json.dumps(ref, indent=1, sort_keys=True) + "\n")
