"""What the agents write: the headline agent of each shape family beside the tuned
controller on every test and held-out (ood_test) shape, the target under both.

    python experiments/shape_agents/agents_gallery.py            # play, then plot (~3 min)
    python experiments/shape_agents/agents_gallery.py --plot     # redraw from the npz files

The headline agent of an environment is chosen on validation only: of the groups exported
under agents/results/<Env>/ (a campaign's ``--export``), the one with the lowest mean
validation error over its seeds (each seed's ``eval/best.json``), played with the model the
export ships (that group's seed selected on validation). Episode k of a set plays its
shape k with reset seed k, as ``bathprint evaluate RUN_DIR --target-set SET`` does, so the
errors here are the evaluation's.

Per environment, results/agents_gallery_<Env>.npz holds, per shape, the target in its own
frame and each policy's written curve moved onto it by the family's rigid motion (as the
whole-shape error compares them; float32, ``N_PLOT`` points), the RMS and largest distance
(mm) and success. The plots read the npz files only: docs/img/agents_gallery_<family>.png
(every shape) and docs/img/agents_gallery.png (two test and two held-out shapes of each
family, the README's picture). Target grey and thick, controller blue, agent green.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))  # experiments/: _common
sys.path.insert(0, str(HERE.parent / "shape_references"))  # the references' gallery
from _common import RESULTS, ROOT, write_meta  # noqa: E402
from gallery import N_PLOT, aligned, policy_arrays  # noqa: E402
from gallery import _panel as ref_panel  # noqa: E402

from bathprint.agents.controller import FAMILY_ENVS, family_shapes  # noqa: E402
from bathprint.envs.shape_geometry import resample  # noqa: E402
from bathprint.envs.shape_metric import arclength_axes, shape_error  # noqa: E402

SETS = ("test", "ood_test")
SET_LABEL = {"test": "test", "ood_test": "ood"}
POLICIES = ("controller", "agent")
COLORS = {"controller": "tab:blue", "agent": "tab:green"}
AGENTS = ROOT / "agents" / "results"
IMG = ROOT / "docs" / "img"
ENV_FAMILY = {env.split("/")[1]: fam for fam, env in FAMILY_ENVS.items()}


def npz_path(env: str) -> Path:
    return RESULTS / f"agents_gallery_{env}.npz"


def headline(env: str) -> tuple[str, Path, float]:
    """(group, shipped run dir, mean validation error in mm) of the environment's group with
    the lowest mean validation error; only groups that ship a model count."""
    best: tuple[str, Path, float] | None = None
    for group in sorted(p for p in (AGENTS / env).iterdir() if p.is_dir()):
        seeds = sorted(group.glob("seed*/eval/best.json"))
        shipped = sorted(group.glob("seed*/eval/best_model.zip"))
        if not seeds or not shipped:
            continue
        val = float(np.mean([json.loads(p.read_text())["mean_metric"] for p in seeds]))
        if best is None or val < best[2]:
            best = (group.name, shipped[0].parents[1], val)
    if best is None:
        raise SystemExit(f"no exported agent with a model under {AGENTS / env}")
    return best


def play(env_name: str) -> Path:
    """Play the controller and the headline agent on every test and ood_test shape."""
    from bathprint.agents.evaluate import run_settings
    from bathprint.agents.policies import load_policy
    from bathprint.agents.rollout import run_episode
    from bathprint.agents.wrappers import wrapper_factory
    from bathprint.envs import make, resolve_id, target_set_size
    from bathprint.envs.shape_files import reference_curve

    env_id = resolve_id(env_name)
    family = ENV_FAMILY[env_name]
    group, run_dir, val = headline(env_name)
    axes = arclength_axes(family)
    rows: list[dict[str, Any]] = []
    for st in SETS:
        shapes = family_shapes(family, st)
        curves: dict[str, list[dict[str, Any]]] = {}
        for pol, spec in (("controller", "controller"), ("agent", str(run_dir))):
            kwargs, wrapper = run_settings(spec, "draft", env_id)
            env = make(env_id, target_set=st, **kwargs)
            if wrapper:
                env = wrapper_factory(wrapper)(env)
            u = env.unwrapped
            if target_set_size(u, st) != len(shapes):
                raise RuntimeError(f"{env_id} {st}: the set and the family's shapes differ")
            policy, _ = load_policy(spec, env, env_id, seed=0)
            out = []
            for k in tqdm(range(len(shapes)), desc=f"{env_name} {st} {pol}", leave=False):
                ep = run_episode(env, policy, k, target_index=k)
                written, ref = u.written_curve(), u.reference_curve
                if ep.truncated or len(written) != len(ref):  # diverged
                    out.append({"written": np.full((N_PLOT, 3), np.nan), "rms_mm": math.nan,
                                "max_mm": math.nan, "success": False})  # fmt: skip
                    continue
                err = shape_error(written, ref, family)
                if not math.isclose(err.rms_mm, ep.metrics["rms_mm"], rel_tol=1e-9):
                    raise RuntimeError(f"{st} {k}: rms {err.rms_mm} != {ep.metrics['rms_mm']}")
                shape = reference_curve(shapes[k][1], env, family)
                out.append({"written": aligned(written, shape, family), "rms_mm": err.rms_mm,
                            "max_mm": err.max_mm, "success": err.success,
                            "target": resample(shape, n=N_PLOT, axes=axes)})  # fmt: skip
            curves[pol] = out
            env.close()
        for k, (name, _) in enumerate(shapes):
            target = next(
                (c[k]["target"] for c in curves.values() if "target" in c[k]),
                np.full((N_PLOT, 3), np.nan),
            )
            rows.append({"set": st, "name": name, "target": target,
                         **{pol: curves[pol][k] for pol in POLICIES}})  # fmt: skip
    arrays: dict[str, np.ndarray] = {
        "sets": np.array([r["set"] for r in rows]),
        "names": np.array([r["name"] for r in rows]),
        "target": np.stack([r["target"] for r in rows]).astype(np.float32),
        "agent_group": np.array(group),
        "agent_run": np.array(run_dir.relative_to(ROOT).as_posix()),
        "agent_validation_mm": np.array(val),
    }
    arrays.update(policy_arrays(rows, POLICIES))
    path = npz_path(env_name)
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, **arrays)  # type: ignore[arg-type]
    write_meta(path)
    return path


def load(env: str) -> dict[str, Any]:
    with np.load(npz_path(env), allow_pickle=False) as z:
        out: dict[str, Any] = {"group": str(z["agent_group"]), "run": str(z["agent_run"]),
                               "shapes": []}  # fmt: skip
        for i, (st, name) in enumerate(zip(z["sets"], z["names"], strict=True)):
            row: dict[str, Any] = {"set": str(st), "name": str(name), "target": z["target"][i]}
            for pol in POLICIES:
                row[pol] = {"written": z[f"written_{pol}"][i],
                            "rms_mm": float(z[f"rms_mm_{pol}"][i]),
                            "success": bool(z[f"success_{pol}"][i])}  # fmt: skip
            out["shapes"].append(row)
    return out


def summary(env: str) -> str:
    d = load(env)
    lines = [f"{env}: agent {d['group']} ({d['run']})"]
    for st in SETS:
        rows = [r for r in d["shapes"] if r["set"] == st]
        parts = []
        for pol in POLICIES:
            rms = np.array([r[pol]["rms_mm"] for r in rows])
            ok = sum(r[pol]["success"] for r in rows)
            parts.append(f"{pol} {np.nanmean(rms):.2f} mm ({ok}/{len(rows)} succeed)")
        lines.append(f"  {st:9s} n={len(rows):2d}: " + ", ".join(parts))
    return "\n".join(lines)


# ---------------------------------------------------------------------------- plot
def _title(row: dict[str, Any]) -> str:
    errs = []
    for pol, short in zip(POLICIES, ("ctl", "agent"), strict=True):
        rms = row[pol]["rms_mm"]
        errs.append(f"{short} {rms:.2f}" if math.isfinite(rms) else f"{short} diverged")
    return f"{row['name']} ({SET_LABEL[row['set']]})\n{' / '.join(errs)} mm"


def _figure(panels: list[tuple[str, dict[str, Any]]], ncol: int, size: float, title: str,
            agent_label: str, path: Path) -> Path:  # fmt: skip
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    nrow = math.ceil(len(panels) / ncol)
    fig = plt.figure(figsize=(ncol * size, nrow * size * 0.95 + 0.7))
    for k, (family, row) in enumerate(panels):
        ax = fig.add_subplot(nrow, ncol, k + 1, projection="3d" if family == "free" else None)
        ref_panel(ax, family, row, POLICIES, COLORS)
        ax.set_title(_title(row), fontsize=6.5, pad=2)
    fig.suptitle(title, fontsize=8)
    handles = [Line2D([], [], color="0.6", lw=3.5, label="target"),
               Line2D([], [], color=COLORS["controller"], lw=1.2, label="controller"),
               Line2D([], [], color=COLORS["agent"], lw=1.2, label=agent_label)]  # fmt: skip
    fig.legend(handles=handles, loc="lower center", fontsize=7, ncol=3, frameon=False)
    h = fig.get_figheight()
    h_pad = 2.0 if any(f == "free" for f, _ in panels) else 0.6
    fig.tight_layout(rect=(0, 0.3 / h, 1, 1 - 0.35 / h), h_pad=h_pad, w_pad=0.4)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=80, metadata={"Software": None})
    plt.close(fig)
    return path


def plot(envs: list[str]) -> list[Path]:
    """docs/img/agents_gallery_<family>.png per environment, and the README's overview."""
    out, overview = [], []
    for env in envs:
        d = load(env)
        family = ENV_FAMILY[env]
        panels = [(family, r) for r in d["shapes"]]
        out.append(_figure(
            panels, 5, 2.6 if family == "free" else 2.4,
            f"{env} ({family}): the headline agent ({d['group']}, selected on validation) and "
            "the controller; RMS error after the family's rigid motion, draft accuracy",
            d["group"], IMG / f"agents_gallery_{family}.png"))  # fmt: skip
        for st in SETS:
            overview += [(family, r) for r in d["shapes"] if r["set"] == st][:2]
    if len(envs) == len(ENV_FAMILY):
        out.append(_figure(
            overview, 4, 2.5,
            "Each family's headline agent (green) and the tuned controller (blue) on two test "
            "and two held-out shapes; target grey; RMS error in mm",
            "agent", IMG / "agents_gallery.png"))  # fmt: skip
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--envs", nargs="+", default=list(ENV_FAMILY), choices=list(ENV_FAMILY))
    ap.add_argument("--plot", action="store_true", help="only draw, from the npz files")
    args = ap.parse_args()
    for env in args.envs:
        if not args.plot:
            play(env)
        print(summary(env))
    for path in plot(args.envs):
        print(f"  -> {path.relative_to(ROOT)} ({path.stat().st_size / 1e3:.0f} kB)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
