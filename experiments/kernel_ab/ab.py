"""A/B wall time of two source trees of bathprint on the same workloads: new / old.

    python experiments/kernel_ab/ab.py [--old-src DIR] [--new-src DIR] [--rounds 5] [--repeats 3]
                                  [--workloads NAME ...]

Every measurement is a fresh subprocess with ``PYTHONPATH`` set to one tree's ``src``
(checked: the worker reports where it imported ``bathprint`` from), so the two trees never
share a process or a numba cache. First each tree runs every workload once, untimed, to
fill its numba cache. Then, in each of ``--rounds`` rounds, every workload runs in the
old and in the new tree back to back (the order alternates between rounds, so a drift in
the machine's load does not favour one tree); a worker builds its state untimed, runs the
workload ``--repeats`` + 1 times on fresh copies, drops the first (loading the compiled
kernels) and reports the best wall time and, apart, the best CPU time of the process. The
ratio of a round is new best / old best; the table gives the median over the rounds, and
the spread, half the range of the rounds' ratios (min and max beside). old_s and new_s are
the medians of the rounds' bests. The CPU-time ratio (``cpu_ratio``) is given as well: on
a machine with more runnable processes than cores, wall time also counts the time a worker
waits for a core, which CPU time does not.

Workloads use the public API only (``Simulation``, ``bathprint.envs``), which both trees
share; each worker also reports a digest of its result (final centreline and step counts,
or the environment's observations and rewards), so the table says whether both trees
computed the same thing bit for bit:

- ``default``: the default scene (paper_simulation), ``advance(3.0)``;
- ``sag N=...``: the sagging filament of scaling.py at N = 100, 1000, 10000, fixed
  2 ms steps after a 20 ms start (2000, 300 and 60 steps);
- ``cantilever SDIRK4 ...``: the inertial cantilever of cantilever.py (b) with
  bathprint's setting there, SDIRK4 at a fixed 1 ms step, modified Newton, to t = 0.5 s, at
  50 and 100 elements;
- ``CoilRadius-v0 draft``: 600 environment steps under seeded random actions (resets
  included), after an untimed episode that fills the per-process warm-up states;
- ``drag_coiling_22G``: 2 s of the scene with effects elasticity, drag, gravity (both trees
  the same physics: newer trees list contact in that scene by default);
- ``period_doubling_22G``: 0.3 s of the scene as it is, with contact (for trees that have
  it) by its sharp onset (``_common.SHARP_CONTACT``, which the trees compared had as
  default): Newton's solves by GMRES preconditioned by the banded LU;
- ``per call``: 2000 ``advance`` calls of one fixed 2 ms step each on a 2-node stub (the
  default scene without flow): the fixed cost of a call from Python, which environments
  pay at every step.

Writes results/kernel_redesign_ab.csv. On a shared machine absolute times move
with the load (the 1-minute load average is recorded); the ratios within a round are the
result.
"""

from __future__ import annotations

import argparse
import copy
import hashlib
import json
import os
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

BENCH_DIR = Path(__file__).resolve().parent
sys.path.insert(0, str(BENCH_DIR.parent))  # experiments/: _common
DEFAULT_OLD = Path("/work/wt/base/src")
DEFAULT_NEW = BENCH_DIR.parents[1] / "src"
STEP_S = 2e-3  # the sagging filament's fixed step
SAG_STEPS = {100: 2000, 1000: 300, 10000: 60}
CANTILEVER_EFFECTS = ["elasticity", "drag", "gravity", "inertia"]
COIL_EFFECTS = ["elasticity", "drag", "gravity"]
ENV_STEPS = 600
CALLS = 2000  # advance() calls of the per-call workload
PILE_SCENE = "period_doubling_22G"  # with its contact: GMRES on the band's LU
PILE_S = 0.3


def _sharp_contact() -> dict:
    """The pile's contact law as the trees compared measured it (``_common.SHARP_CONTACT``,
    without the dashpot's key, which older trees lack: overdamped, the pile has none)."""
    from _common import SHARP_CONTACT

    return {k: v for k, v in SHARP_CONTACT.items() if k != "contact.damping_time_s"}


# ================================================================== workloads (worker side)
def _sim_digest(sim) -> str:
    """Final centreline and the step counters both trees report."""
    c = sim.counts()
    h = hashlib.sha1(sim.centerline().tobytes())
    for key in ("steps", "rejected_steps", "newton_iterations", "nodes_born"):
        h.update(str(c[key]).encode())
    return h.hexdigest()[:12]


def _sim_workload(make: Callable[[], object], run: Callable[[object], None]):
    """A workload on a Simulation: ``make`` builds (and may pre-advance) it, untimed, once
    per process; each call takes a fresh copy and ``run`` is what is timed."""
    cache: dict[str, object] = {}

    def prepare() -> tuple[Callable[[], object], Callable[[object], str]]:
        if "base" not in cache:
            cache["base"] = make()
        sim = copy.deepcopy(cache["base"])
        return (lambda: run(sim) or sim), _sim_digest

    return prepare


def _default_scene():
    from bathprint import Simulation

    return _sim_workload(
        lambda: Simulation("paper_simulation", {"duration_s": 3.0}), lambda s: s.advance(3.0)
    )


def _sagging(n: int):
    from _common import sagging_filament

    steps = SAG_STEPS[n]

    def make():
        sim = sagging_filament(n, STEP_S)
        sim.advance(0.02)  # leave the start-up transient (as scaling.py)
        return sim

    return _sim_workload(make, lambda s: s.advance(s.t + steps * STEP_S))


def _cantilever(n: int):
    from bathprint import Simulation

    def make():
        return Simulation(
            "cantilever_water",
            {
                "effects": CANTILEVER_EFFECTS,
                "numerics.node_spacing_mm": 10.0 / n,
                "numerics.tolerance": 1e-6,
                "numerics.integrator": "sdirk4",
                "numerics.time_step_s": 1e-3,
                "numerics.newton": "modified",
            },
        )

    return _sim_workload(make, lambda s: s.advance(0.5))


def _drag_coiling():
    from bathprint import Simulation

    return _sim_workload(
        lambda: Simulation("drag_coiling_22G", {"duration_s": 2.0, "effects": COIL_EFFECTS}),
        lambda s: s.advance(2.0),
    )


def _pile():
    from bathprint import Simulation

    return _sim_workload(
        lambda: Simulation(
            PILE_SCENE, {"duration_s": PILE_S, "outputs.plot": False, **_sharp_contact()}
        ),
        lambda s: s.advance(PILE_S),
    )


def _per_call():
    """Many short ``advance`` calls: the cost of a call that integrates almost nothing (one
    2 ms step of a 2-node stub), which is what an environment step pays besides its
    physics."""
    from bathprint import Simulation

    def make():
        over = {"flow.q_outer_ml_min": 0.0, "numerics.time_step_s": STEP_S, "duration_s": 100.0}
        sim = Simulation("paper_simulation", over)
        sim.advance(0.02)
        return sim

    def run(sim) -> None:
        for _ in range(CALLS):
            sim.advance(sim.t + STEP_S)

    return _sim_workload(make, run)


def _coil_radius_env():
    import numpy as np

    import bathprint.envs as E

    cache: dict[str, object] = {}

    def prepare():
        if "env" not in cache:
            env = E.make("bathprint/CoilRadius-v0", accuracy="draft")
            env.action_space.seed(0)
            env.reset(seed=0)
            done = False
            while not done:  # an untimed episode: fills the per-process warm-up states
                _, _, term, trunc, _ = env.step(env.action_space.sample())
                done = term or trunc
            cache["env"] = env
        env = cache["env"]

        def run():
            h = hashlib.sha1()
            env.action_space.seed(0)
            obs, _ = env.reset(seed=0)
            for _ in range(ENV_STEPS):
                obs, reward, term, trunc, _ = env.step(env.action_space.sample())
                h.update(np.asarray(obs).tobytes())
                h.update(np.float64(reward).tobytes())
                if term or trunc:
                    obs, _ = env.reset()
            return h

        return run, lambda h: h.hexdigest()[:12]

    return prepare


WORKLOADS: dict[str, Callable[[], Callable]] = {
    "default scene (3 s)": _default_scene,
    **{f"sag N={n} ({SAG_STEPS[n]} steps)": (lambda n=n: _sagging(n)) for n in SAG_STEPS},
    **{f"cantilever SDIRK4 1 ms, {n} el. (0.5 s)": (lambda n=n: _cantilever(n)) for n in (50, 100)},
    f"CoilRadius-v0 draft ({ENV_STEPS} steps)": _coil_radius_env,
    "drag_coiling_22G 2 s (no contact)": _drag_coiling,
    "period_doubling_22G 0.3 s (contact)": _pile,
    f"per call: {CALLS} advance() of 1 step": _per_call,
}


def worker(name: str, repeats: int) -> None:
    """Run one workload ``repeats`` + 1 times (the first untimed) and print a JSON line."""
    import bathprint

    prepare = WORKLOADS[name]()
    times, cpu = [], []
    digest = ""
    for _ in range(repeats + 1):
        run, digest_of = prepare()
        t0, c0 = time.perf_counter(), time.process_time()
        result = run()
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
        digest = digest_of(result)
    kept = slice(1, None) if repeats > 0 else slice(None)
    out = {
        "workload": name,
        "best_s": min(times[kept]),
        "best_cpu_s": min(cpu[kept]),
        "times": times,
        "digest": digest,
        "bathprint": str(Path(bathprint.__file__).resolve().parent),
    }
    print("AB-RESULT " + json.dumps(out), flush=True)


# ================================================================== driver
def _run_worker(src: Path, name: str, repeats: int) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(src), str(BENCH_DIR.parent)])  # + _common
    cmd = [sys.executable, str(Path(__file__).resolve()), "--worker", name]
    proc = subprocess.run(
        [*cmd, "--repeats", str(repeats)], env=env, capture_output=True, text=True, check=False
    )
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("AB-RESULT ")]
    if proc.returncode != 0 or not lines:
        raise RuntimeError(f"worker {name!r} in {src} failed:\n{proc.stderr[-3000:]}")
    res = json.loads(lines[-1][len("AB-RESULT ") :])
    expected = (src / "bathprint").resolve()
    if Path(res["bathprint"]) != expected:
        raise RuntimeError(f"worker imported bathprint from {res['bathprint']}, not {expected}")
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--old-src", type=Path, default=DEFAULT_OLD)
    ap.add_argument("--new-src", type=Path, default=DEFAULT_NEW)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--repeats", type=int, default=3, help="timed runs per worker (best kept)")
    ap.add_argument("--workloads", nargs="*", default=list(WORKLOADS), choices=list(WORKLOADS))
    ap.add_argument("--out", default="kernel_redesign_ab", help="results/NAME.csv")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        worker(args.worker, args.repeats)
        return
    from _common import write_csv

    trees = {"old": args.old_src.resolve(), "new": args.new_src.resolve()}
    for label, src in trees.items():
        if not (src / "bathprint" / "__init__.py").is_file():
            sys.exit(f"--{label}-src = {src}: no bathprint package there")
    t_start = time.perf_counter()
    print(f"old: {trees['old']}\nnew: {trees['new']}\nload average: {os.getloadavg()}")
    for label, src in trees.items():  # fill each tree's numba cache, untimed
        t0 = time.perf_counter()
        for name in args.workloads:
            _run_worker(src, name, 0)
        print(f"warmed {label} in {time.perf_counter() - t0:.0f} s", flush=True)
    best: dict[str, dict[str, list[float]]] = {w: {"old": [], "new": []} for w in args.workloads}
    best_cpu: dict[str, dict[str, list[float]]] = {w: {"old": [], "new": []} for w in best}
    digests: dict[str, dict[str, set[str]]] = {w: {"old": set(), "new": set()} for w in best}
    loads: list[float] = []
    for r in range(args.rounds):
        order = ("old", "new") if r % 2 == 0 else ("new", "old")
        for name in args.workloads:
            for label in order:
                loads.append(os.getloadavg()[0])
                res = _run_worker(trees[label], name, args.repeats)
                best[name][label].append(res["best_s"])
                best_cpu[name][label].append(res["best_cpu_s"])
                digests[name][label].add(res["digest"])
            b, c = best[name], best_cpu[name]
            print(
                f"round {r + 1}/{args.rounds} {name:<40} old {b['old'][-1]:.4g} s "
                f"new {b['new'][-1]:.4g} s  ratio {b['new'][-1] / b['old'][-1]:.3f} "
                f"(cpu {c['new'][-1] / c['old'][-1]:.3f})",
                flush=True,
            )
    rows = []
    for name, b in best.items():
        ratios = [n / o for n, o in zip(b["new"], b["old"], strict=True)]
        c = best_cpu[name]
        cpu_ratios = [n / o for n, o in zip(c["new"], c["old"], strict=True)]
        d = digests[name]
        rows.append(
            {
                "workload": name,
                "old_s": round(statistics.median(b["old"]), 6),
                "new_s": round(statistics.median(b["new"]), 6),
                "ratio": round(statistics.median(ratios), 4),
                "rounds": args.rounds,
                "spread": round((max(ratios) - min(ratios)) / 2, 4),
                "ratio_min": round(min(ratios), 4),
                "ratio_max": round(max(ratios), 4),
                "old_cpu_s": round(statistics.median(c["old"]), 6),
                "new_cpu_s": round(statistics.median(c["new"]), 6),
                "cpu_ratio": round(statistics.median(cpu_ratios), 4),
                "cpu_spread": round((max(cpu_ratios) - min(cpu_ratios)) / 2, 4),
                "identical": len(d["old"]) == 1 and d["old"] == d["new"],
                "load_avg_1min": round(statistics.mean(loads), 2),
            }
        )
    print()
    head = (
        f"{'workload':<40}{'old s':>10}{'new s':>10}{'new/old':>9}{'spread':>8}"
        f"{'min-max':>15}{'cpu new/old':>13}{'spread':>8}  same result"
    )
    print(head)
    print("-" * len(head))
    for row in rows:
        print(
            f"{row['workload']:<40}{row['old_s']:>10.4g}{row['new_s']:>10.4g}"
            f"{row['ratio']:>9.3f}{row['spread']:>8.3f}"
            f"{row['ratio_min']:>9.3f}-{row['ratio_max']:.3f}{row['cpu_ratio']:>13.3f}"
            f"{row['cpu_spread']:>8.3f}  {row['identical']}"
        )
    print(
        f"\n{args.rounds} rounds x best of {args.repeats}; load average (1 min) during the "
        f"rounds {min(loads):.2f}-{max(loads):.2f} on {os.cpu_count()} CPUs"
    )
    print("wrote", write_csv(args.out, rows))
    print(f"total {time.perf_counter() - t_start:.0f} s")


if __name__ == "__main__":
    main()
