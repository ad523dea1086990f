"""Behaviour-cloning search on the validation targets: which demonstrations and which policy
size make a cloned policy write WriteShape-v1's targets.

Each row clones a fresh PPO policy (``MlpPolicy``, two tanh layers of ``net_width``) on the
printing actions of the first ``targets`` training targets, each played ``replays`` times
(every other episode with N(0, ``action_noise``) on the played action, white or, with
``noise_correlation`` rho, AR(1) from step to step; :func:`bathprint.agents.imitation.
collect_demonstrations`), for ``epochs`` passes (:func:`~bathprint.agents.imitation.
fit_policy`, Adam 1e-3, batches of 256), and plays the cloned policy deterministically on
the 16 validation targets (target k with seed k, as the validation callback plays them).
No PPO step is taken and the test targets are never read. ``--seed`` seeds the noise and
the fit (rows are kept per seed). The row chosen here is the ``bc_pretrain`` of
``agents/ppo_bc.yml`` for the environment.

    python experiments/bc_search/bc_search.py                 # all rows (about 25 min on a core)
    python experiments/bc_search/bc_search.py --rows 0 --targets-scale 0.02   # a smoke run

Rows already in the CSV are kept (the search resumes after a kill); ``--fresh`` starts over.
Writes results/bc_search_<Env>.csv (+ .meta.json).

``--diagnose ROW`` measures where the cloned policy's error comes from, on the validation
targets: its actions teacher-forced on the printing actions' own states (RMS to them), and
the printing actions replayed with white noise of each std in ``NOISE_STDS`` (the metric an
uncorrelated action error of that size costs); results/bc_search_<Env>_diagnosis.csv.

``--dagger ROW`` tries DAgger (Ross, Gordon & Bagnell 2011) on that row's cloned policy: each
of ``--rounds`` rounds plays the current policy (deterministic) on the next
``--round-targets`` training targets, labels every visited state with an expert's action,
adds the pairs to the demonstrations and refits for ``--refit-epochs``; after every round
the policy plays the validation targets. Two experts, both free to query: ``printing`` (the
target's own printing action at that step: time-indexed) and ``aligned`` (the same with its
needle velocity mapped by the rotation or reflection about the vertical that best aligns the
last 15 mm of target with what has been scored, so that it points the way the printed curve
has turned). Each expert is also played itself, on the validation targets, with the AR(1)
noise (std 0.15, rho 0.9) whose drift is like a cloned policy's error.
results/bc_search_<Env>_dagger.csv.

``--ensemble K`` (with ``--ensemble-row ROW``, default 5) fits an ensemble policy of K actors
(:class:`bathprint.agents.ensemble.EnsembleMlpPolicy`, each actor fitted on its own, seed +
k) on that row's demonstrations and plays every actor alone and their mean on the
validation targets: what averaging the clones' errors is worth.
results/bc_search_<Env>_ensemble.csv.

``--frame-stack K,...`` clones that row's policy on observations stacked over the last K
steps (gymnasium's ``FrameStackObservation``, the first observation repeated at a reset;
K = 1 is the row itself) and plays it on the validation targets: whether the observation's
history says what one observation does not. Rows are kept per (K, seed), so runs with
other seeds add to the file. results/bc_search_<Env>_frame_stack.csv.
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # experiments/: _common
from _common import RESULTS, write_meta  # noqa: E402

#: (training targets, action noise std, net width, epochs, replays, noise correlation)
ROWS: list[tuple[int, float, int, int, int, float]] = [
    (160, 0.15, 128, 30, 1, 0.0),  # CoilRadius-v1's setting
    (1024, 0.0, 128, 30, 1, 0.0),
    (1024, 0.15, 128, 30, 1, 0.0),
    (1024, 0.15, 128, 60, 1, 0.0),
    (1024, 0.3, 128, 60, 1, 0.0),
    (1024, 0.15, 256, 30, 1, 0.0),
    (1024, 0.15, 256, 100, 1, 0.0),
    # each target played twice (clean, noisy); noise correlated from step to step
    (1024, 0.15, 256, 30, 2, 0.0),
    (1024, 0.15, 256, 30, 1, 0.9),
    (1024, 0.15, 256, 30, 2, 0.9),
    (1024, 0.3, 256, 30, 2, 0.9),
    (1024, 0.15, 256, 30, 2, 0.7),
]
NOISE_STDS = (0.0, 0.05, 0.1, 0.2, 0.4)  # white noise on replayed printing actions (--diagnose)
FIELDS = [
    "targets", "action_noise", "net_width", "epochs", "replays", "noise_correlation", "seed",
    "demonstration_pairs", "mse_after",
    "validation_mean_metric", "validation_ci_low", "validation_ci_high",
    "validation_success_rate", "collect_wall_s", "fit_wall_s",
]  # fmt: skip


def _key(row: dict) -> tuple:
    """A row's settings and seed (rows written before replays, correlation and seed were
    columns are replays 1, white noise, seed 0)."""
    return (int(row["targets"]), float(row["action_noise"]), int(row["net_width"]),
            int(row["epochs"]), int(row.get("replays") or 1),
            float(row.get("noise_correlation") or 0.0), int(row.get("seed") or 0))  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--env", default="bathprint/WriteShape-v1")
    ap.add_argument("--rows", default=None, help="comma-separated row indices (default all)")
    ap.add_argument("--episodes", type=int, default=16, help="validation targets played")
    ap.add_argument("--targets-scale", type=float, default=1.0,
                    help="multiply each row's training targets (smoke runs)")  # fmt: skip
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default=None, help="CSV path (default results/...)")
    ap.add_argument("--fresh", action="store_true", help="discard rows already in the CSV")
    ap.add_argument("--diagnose", type=int, default=None, metavar="ROW",
                    help="diagnose one row (teacher-forced, noisy replays) instead")  # fmt: skip
    ap.add_argument("--dagger", type=int, default=None, metavar="ROW",
                    help="DAgger rounds on one row's cloned policy instead")  # fmt: skip
    ap.add_argument("--rounds", type=int, default=3, help="DAgger rounds")
    ap.add_argument("--round-targets", type=int, default=512, help="targets per DAgger round")
    ap.add_argument("--refit-epochs", type=int, default=10, help="epochs per DAgger refit")
    ap.add_argument("--ensemble", type=int, default=None, metavar="K",
                    help="fit K actors on one row's demonstrations instead")  # fmt: skip
    ap.add_argument("--ensemble-row", type=int, default=5, metavar="ROW")
    ap.add_argument("--frame-stack", default=None, metavar="K,...",
                    help="clone --ensemble-row's policy on K stacked observations")  # fmt: skip
    args = ap.parse_args(argv)
    if args.frame_stack is not None:
        return frame_stack(args)
    if args.ensemble is not None:
        return ensemble(args)
    if args.diagnose is not None:
        return diagnose(args)
    if args.dagger is not None:
        return dagger(args)

    import torch
    from rich.progress import track

    from bathprint.agents.imitation import collect_demonstrations
    from bathprint.agents.rollout import run_episode
    from bathprint.agents.statistics import bootstrap_ci
    from bathprint.envs import make

    torch.set_num_threads(1)
    name = args.env.split("/")[-1]
    out = Path(args.out) if args.out else RESULTS / f"bc_search_{name}.csv"
    out.parent.mkdir(parents=True, exist_ok=True)
    done: list[dict] = []
    if out.exists() and not args.fresh:
        with out.open() as f:
            done = list(csv.DictReader(f))
    have = {_key(r) for r in done}
    picked = range(len(ROWS)) if args.rows is None else [int(i) for i in args.rows.split(",")]
    todo = []
    for i in picked:
        n, noise, width, epochs, replays, rho = ROWS[i]
        n = max(1, round(n * args.targets_scale))
        todo.append((n, noise, width, epochs, replays, rho, args.seed))
    todo = [r for r in todo if r not in have]
    for r in done:  # rows of earlier versions of this file: fill the new columns
        r.update(zip(("replays", "noise_correlation", "seed"), _key(r)[4:], strict=True))
    demos_cache: dict[tuple[int, float, int, float], object] = {}
    env_kwargs = {"accuracy": "draft"}
    val_env = make(args.env, target_set="validation", **env_kwargs)
    try:
        for n, noise, width, epochs, replays, rho, _ in todo:
            if (n, noise, replays, rho) not in demos_cache:
                demos_cache[(n, noise, replays, rho)] = collect_demonstrations(
                    args.env, env_kwargs, n, args.seed, noise, replays, rho
                )
            demos = demos_cache[(n, noise, replays, rho)]
            what = f"{n} targets x {replays}, noise {noise} (rho {rho}), {width}x2, {epochs} epochs"
            model, fit = _fitted(val_env, demos, width, epochs, args.seed)
            metrics, success = [], []
            for k in track(range(args.episodes), description=what):
                ep = run_episode(val_env, model, seed=k, target_index=k)
                metrics.append(ep.metrics["metric"])
                success.append(ep.is_success)
            m = np.array(metrics)
            _, lo, hi = bootstrap_ci(np.mean, m[None, :], seed=args.seed)
            row = {
                "targets": n, "action_noise": noise, "net_width": width, "epochs": epochs,
                "replays": replays, "noise_correlation": rho, "seed": args.seed,
                "demonstration_pairs": len(demos.obs), "mse_after": fit["mse_after"],
                "validation_mean_metric": float(m.mean()), "validation_ci_low": lo,
                "validation_ci_high": hi, "validation_success_rate": float(np.mean(success)),
                "collect_wall_s": demos.wall_time_s, "fit_wall_s": fit["fit_wall_time_s"],
            }  # fmt: skip
            done.append(row)
            with out.open("w", newline="") as f:  # rewritten whole after every row
                w = csv.DictWriter(f, fieldnames=FIELDS)
                w.writeheader()
                w.writerows(done)
            write_meta(out)
            print(f"{what}: validation {m.mean():.3f} [{lo:.3f}, {hi:.3f}] "
                  f"({time.strftime('%H:%M:%S')})", flush=True)  # fmt: skip
    finally:
        val_env.close()
    print(f"wrote {out}")
    return 0


def _part_row(args: argparse.Namespace, row: int, part: str) -> tuple[Path, tuple]:
    """A part's CSV (``--out``, else results/bc_search_<Env>_<part>.csv) and search row
    ``row``'s settings, its training targets scaled by ``--targets-scale``."""
    name = args.env.split("/")[-1]
    out = Path(args.out) if args.out else RESULTS / f"bc_search_{name}_{part}.csv"
    n, noise, width, epochs, replays, rho = ROWS[row]
    return out, (max(1, round(n * args.targets_scale)), noise, width, epochs, replays, rho)


def _fitted(env: object, demos: object, width: int, epochs: int, seed: int) -> tuple:
    """A fresh PPO model (two tanh layers of ``width``) whose policy is cloned on ``demos``
    (no PPO step), and the fit's record."""
    from stable_baselines3 import PPO

    from bathprint.agents.imitation import fit_policy

    model = PPO("MlpPolicy", env, seed=seed, device="cpu",
                policy_kwargs={"net_arch": [width, width], "log_std_init": -3.0})  # fmt: skip
    return model, fit_policy(model.policy, demos, epochs, 256, 1.0e-3, seed)


def _replay_printing(
    env, k: int, rng, std: float, before_step=None, rho: float = 0.0, expert: str = "printing"
) -> float:
    """Play validation target k's own printing actions (the ``aligned`` expert's with
    ``expert``, :func:`_expert`), plus noise of std ``std`` from ``rng`` (white, or AR(1)
    with ``rho``; clipped to [-1, 1]; none if ``rng`` is None), calling
    ``before_step(obs, action)`` before each step; returns the final metric."""
    u = env.unwrapped
    obs, _ = env.reset(seed=k, options={"target_index": k})
    printing = np.asarray(u.actions_for(u.target), np.float32)
    drift = np.zeros(printing.shape[1])
    for t in range(10_000):
        a = _expert(u, expert, printing, t)
        if before_step is not None:
            before_step(obs, a)
        if rng is not None:
            e = rng.normal(0.0, std, a.shape)
            drift = e if t == 0 else rho * drift + np.sqrt(1.0 - rho * rho) * e
            a = np.clip(a + drift, -1, 1).astype(np.float32)
        obs, _, term, trunc, info = env.step(a)
        if term or trunc:
            break
    return float(info["metric"])


def diagnose(args: argparse.Namespace) -> int:
    """Teacher-forced action error of the cloned policy and noisy replays of the printing
    actions, on the validation targets."""
    import torch

    from bathprint.agents.imitation import collect_demonstrations
    from bathprint.envs import make

    torch.set_num_threads(1)
    out, (n, noise, width, epochs, replays, rho) = _part_row(args, args.diagnose, "diagnosis")
    env = make(args.env, target_set="validation", accuracy="draft")
    rows: list[dict] = []
    try:
        demos = collect_demonstrations(args.env, {"accuracy": "draft"}, n, args.seed, noise,
                                       replays, rho)  # fmt: skip
        model, _ = _fitted(env, demos, width, epochs, args.seed)
        sq = [0.0, 0]  # sum of squared action errors, actions compared

        def compare(obs: np.ndarray, a: np.ndarray) -> None:
            pred, _ = model.predict(obs, deterministic=True)
            sq[0] += float(np.sum((np.asarray(pred) - a) ** 2))
            sq[1] += a.size

        for k in range(args.episodes):
            _replay_printing(env, k, None, 0.0, compare)
        rows.append({"what": "cloned policy, teacher-forced: action RMS to the printing "
                     "actions", "noise_std": "", "value": (sq[0] / sq[1]) ** 0.5})  # fmt: skip
        rng = np.random.default_rng(args.seed)
        for std in NOISE_STDS:
            metrics = [_replay_printing(env, k, rng, std) for k in range(args.episodes)]
            rows.append({"what": "printing actions replayed with white noise: mean metric",
                         "noise_std": std, "value": float(np.mean(metrics))})  # fmt: skip
            print(f"noise {std}: {np.mean(metrics):.3f}", flush=True)
    finally:
        env.close()
    with out.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["what", "noise_std", "value"])
        w.writeheader()
        w.writerows(rows)
    write_meta(out)
    print(f"teacher-forced action RMS {rows[0]['value']:.3f}; wrote {out}")
    return 0


class _Member:
    """Actor k of an ensemble policy alone, with SB3's ``predict`` signature."""

    def __init__(self, policy, k: int) -> None:
        self.policy, self.k = policy, k

    def predict(self, obs, state=None, episode_start=None, deterministic=True):
        import torch

        o = np.asarray(obs, np.float32)
        one = o.ndim == 1
        with torch.no_grad():
            t = torch.as_tensor(o[None] if one else o, device=self.policy.device)
            a = self.policy.member_mean(t, self.k).cpu().numpy()
        space = self.policy.action_space  # clipped as SB3's predict clips a Box action
        a = np.clip(a, space.low, space.high)
        return (a[0] if one else a), None


def ensemble(args: argparse.Namespace) -> int:
    """An ensemble of ``args.ensemble`` actors cloned on one row's demonstrations: each actor
    alone and their mean, on the validation targets."""
    import torch
    from stable_baselines3 import PPO

    from bathprint.agents.ensemble import EnsembleMlpPolicy
    from bathprint.agents.imitation import collect_demonstrations, fit_policy
    from bathprint.agents.rollout import run_episode
    from bathprint.agents.statistics import bootstrap_ci
    from bathprint.envs import make

    torch.set_num_threads(1)
    out, (n, noise, width, epochs, replays, rho) = _part_row(args, args.ensemble_row, "ensemble")
    env = make(args.env, target_set="validation", accuracy="draft")
    rows: list[dict] = []
    try:
        demos = collect_demonstrations(args.env, {"accuracy": "draft"}, n, args.seed, noise,
                                       replays, rho)  # fmt: skip
        model = PPO(EnsembleMlpPolicy, env, seed=args.seed, device="cpu",
                    policy_kwargs={"net_arch": [width, width], "log_std_init": -3.0,
                                   "members": args.ensemble})  # fmt: skip
        fit = fit_policy(model.policy, demos, epochs, 256, 1.0e-3, args.seed)
        players = [(f"actor {k}", _Member(model.policy, k)) for k in range(args.ensemble)]
        players.append((f"mean of {args.ensemble}", model))
        for label, player in players:
            m = np.array([run_episode(env, player, seed=k, target_index=k).metrics["metric"]
                          for k in range(args.episodes)])  # fmt: skip
            _, lo, hi = bootstrap_ci(np.mean, m[None, :], seed=args.seed)
            rows.append({"policy": label, "row": args.ensemble_row, "seed": args.seed,
                         "demonstration_pairs": len(demos.obs),
                         "validation_mean_metric": float(m.mean()), "validation_ci_low": lo,
                         "validation_ci_high": hi,
                         "fit_wall_s": fit["fit_wall_time_s"]})  # fmt: skip
            print(f"{label}: validation {m.mean():.3f} [{lo:.3f}, {hi:.3f}]", flush=True)
    finally:
        env.close()
    with out.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    write_meta(out)
    print(f"wrote {out}")
    return 0


def frame_stack(args: argparse.Namespace) -> int:
    """One row's cloned policy on observations stacked over K steps, per K (module doc)."""
    import torch
    from gymnasium.wrappers import FrameStackObservation
    from rich.progress import track

    from bathprint.agents.imitation import collect_demonstrations
    from bathprint.agents.rollout import run_episode
    from bathprint.agents.statistics import bootstrap_ci
    from bathprint.envs import make

    torch.set_num_threads(1)
    out, (n, noise, width, epochs, replays, rho) = _part_row(args, args.ensemble_row, "frame_stack")
    stacks = [int(k) for k in str(args.frame_stack).split(",")]
    if any(k < 1 for k in stacks):
        raise SystemExit(f"--frame-stack {args.frame_stack!r}: every K must be >= 1")
    rows = list(csv.DictReader(out.open())) if out.exists() and not args.fresh else []
    have = {(int(r["frames"]), int(r["seed"])) for r in rows}
    for k in stacks:
        if (k, args.seed) in have:
            continue

        def wrap(env, k=k):
            return FrameStackObservation(env, k) if k > 1 else env

        demos = collect_demonstrations(args.env, {"accuracy": "draft"}, n, args.seed, noise,
                                       replays, rho, wrap=wrap)  # fmt: skip
        val = wrap(make(args.env, target_set="validation", accuracy="draft"))
        try:
            model, fit = _fitted(val, demos, width, epochs, args.seed)
            played = track(range(args.episodes), description=f"{k} frames")
            m = np.array([run_episode(val, model, seed=i, target_index=i).metrics["metric"]
                          for i in played])  # fmt: skip
        finally:
            val.close()
        _, lo, hi = bootstrap_ci(np.mean, m[None, :], seed=args.seed)
        rows.append({"frames": k, "row": args.ensemble_row, "seed": args.seed,
                     "demonstration_pairs": len(demos.obs), "mse_after": fit["mse_after"],
                     "validation_mean_metric": float(m.mean()), "validation_ci_low": lo,
                     "validation_ci_high": hi,
                     "collect_wall_s": demos.wall_time_s,
                     "fit_wall_s": fit["fit_wall_time_s"]})  # fmt: skip
        with out.open("w", newline="") as f:  # rewritten whole after every row
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
        write_meta(out)
        print(f"{k} frames: validation {m.mean():.3f} [{lo:.3f}, {hi:.3f}]", flush=True)
    print(f"wrote {out}")
    return 0


ALIGN_SAMPLES = 30  # the aligned expert's window: the last 30 scored samples (15 mm)


def _frame(u) -> np.ndarray:
    """The 2x2 orthogonal map (rotation or reflection) that best takes the target's last
    ``ALIGN_SAMPLES`` scored samples onto what has been scored of them (horizontal plane,
    Kabsch); the identity before 4 are scored."""
    j = u._n_scored
    if j < 4:
        return np.eye(2)
    k = min(ALIGN_SAMPLES, j)
    p = u._rec_pts[j - k : j, :2] - u._rec_pts[j - k : j, :2].mean(0)
    q = u.target.points_mm[j - k : j, :2] - u.target.points_mm[j - k : j, :2].mean(0)
    w, _, vt = np.linalg.svd(q.T @ p)
    return vt.T @ w.T


def _expert(u, name: str, printing: np.ndarray, t: int) -> np.ndarray:
    """The expert's action at step t: the printing action, or it with its needle velocity
    mapped by :func:`_frame` (``aligned``)."""
    a = printing[min(t, len(printing) - 1)].copy()
    if name == "aligned":
        a[1:3] = np.clip(_frame(u) @ a[1:3], -1, 1)
    return a


def dagger(args: argparse.Namespace) -> int:
    """DAgger rounds with each expert on one row's cloned policy (module doc)."""
    import torch

    from bathprint.agents.imitation import (
        Demonstrations,
        _action_mean,
        collect_demonstrations,
        fit_policy,
    )
    from bathprint.agents.rollout import run_episode
    from bathprint.agents.statistics import bootstrap_ci
    from bathprint.envs import make

    torch.set_num_threads(1)
    out, (n, noise, width, epochs, replays, rho) = _part_row(args, args.dagger, "dagger")
    kw = {"accuracy": "draft"}
    val = make(args.env, target_set="validation", **kw)
    env = make(args.env, target_set="train", **kw)
    u, rows = env.unwrapped, []
    demos = collect_demonstrations(args.env, kw, n, args.seed, noise, replays, rho)

    def record(expert: str, rnd: int, pairs: int, mse: float, wall: float, model) -> None:
        m = np.array([run_episode(val, model, seed=k, target_index=k).metrics["metric"]
                      for k in range(args.episodes)])  # fmt: skip
        _, lo, hi = bootstrap_ci(np.mean, m[None, :], seed=args.seed)
        rows.append({"expert": expert, "round": rnd, "pairs": pairs, "mse_after": mse,
                     "validation_mean_metric": float(m.mean()), "validation_ci_low": lo,
                     "validation_ci_high": hi, "round_wall_s": wall})  # fmt: skip
        print(f"{expert} round {rnd}: {pairs} pairs, mse {mse:.4f}, validation "
              f"{m.mean():.3f} [{lo:.3f}, {hi:.3f}]", flush=True)  # fmt: skip

    try:
        for expert in ("printing", "aligned"):
            rng = np.random.default_rng(args.seed)
            played = [_replay_printing(val, k, rng, 0.15, rho=0.9, expert=expert)
                      for k in range(args.episodes)]  # fmt: skip
            rows.append({"expert": expert, "round": "expert + AR(1) noise 0.15",
                         "validation_mean_metric": float(np.mean(played))})  # fmt: skip
            t0 = time.perf_counter()
            model, fit = _fitted(val, demos, width, epochs, args.seed)
            record(expert, 0, len(demos.obs), fit["mse_after"], time.perf_counter() - t0, model)
            obs, act, cursor = [demos.obs], [demos.actions], 0
            for r in range(1, args.rounds + 1):
                t0 = time.perf_counter()
                for _ in range(args.round_targets):
                    s = cursor % u.printed.train_pool
                    cursor += 1
                    target = u.printed.get(s)
                    printing = np.asarray(u.actions_for(target), np.float32)
                    o, _ = env.reset(seed=args.seed * 100_003 + s, options={"target": target})
                    for t in range(10_000):
                        obs.append(np.asarray(o, np.float32)[None])
                        act.append(_expert(u, expert, printing, t)[None].astype(np.float32))
                        with torch.no_grad():
                            a = _action_mean(model.policy, torch.as_tensor(o[None]))[0].numpy()
                        o, _, term, trunc, _ = env.step(np.clip(a, -1, 1).astype(np.float32))
                        if term or trunc:
                            break
                agg = Demonstrations(np.concatenate(obs), np.concatenate(act), [], [], 0.0)
                fit = fit_policy(model.policy, agg, args.refit_epochs, 256, 1.0e-3,
                                 args.seed + r)  # fmt: skip
                record(expert, r, len(agg.obs), fit["mse_after"], time.perf_counter() - t0,
                       model)  # fmt: skip
    finally:
        val.close()
        env.close()
    fields = ["expert", "round", "pairs", "mse_after", "validation_mean_metric",
              "validation_ci_low", "validation_ci_high", "round_wall_s"]  # fmt: skip
    with out.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)
    write_meta(out)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
