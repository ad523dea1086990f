"""What self-contact costs: per step against N, and in the coiling scenes.

(1) A stress-free coil stack of N nodes (22G filament, radius 3 mm) sinking under its
weight for 20 ms (adaptive steps) after its first 2 ms (timed apart: drawn pressed into
contact everywhere, a stack first relaxes): with its turns 1.5 contact distances apart (candidate
pairs, none touching), N = 10^2 .. 10^4, and with its turns pressed to 0.98 of the contact
distance (every turn touching the next: a chain of contacts as high as the stack),
N = 10^2 .. 10^4, with GMRES preconditioned by the banded LU and (``numerics.preconditioner
= "axial_coarse"``) by the banded LU and an axial coarse correction. Wall time per step and
per node-step with and without contact (the pair search included), Krylov iterations per
Newton iteration; ``--part settled``: the pressed stacks, 300 to 10^4 nodes, after 20 ms
(when they have relaxed), at steps of at most 0.25 ms, for 20 ms more; the stacks hold
contact's former default law, the sharp onset (``_common.SHARP_CONTACT``), and
``--part scaling_default`` and ``--part settled_default`` run the pressed ones with its
default law. (At a fixed 1 ms step the
pressed stack's Newton matrix is indefinite, -P' Hess d exceeding the drag term, and GMRES
stalls: the adaptive steps are shorter there.) (2) drag_coiling_22G (4 s) and period_doubling_22G
(0.5 s) with and without contact: wall time ratio, Krylov iterations per Newton iteration,
steps, and the smallest distance between non-adjacent segments over the saved frames.
Every ratio is measured within the same run. (3) ``--part whole``: every built-in scene that
lists contact, for its whole duration as shipped, with the smallest distance between
non-adjacent segments over all its saved frames (the validation's "never closer than 0.9
contact distances", for whole runs; tests/test_contact.py checks shortened ones). (4)
``--part saturation``: the pressed stacks from 300 to 3x10^4 nodes (5 to 477 turns), relaxed
20 ms, then 5 ms at steps of at most 0.25 and 0.0625 ms from copies of the relaxed state:
Krylov iterations per Newton iteration against the bound that a model of the stack gives
for GMRES with the banded LU (``stack_coupling``), which stops growing with the height.
(5) ``--part hessian``: every built-in scene with contact, its whole run with the exact
Hessian of the penalty (the default) and with its Gauss-Newton part (``contact.hessian``),
best of two each.

    python experiments/contact_cost/contact_cost.py [--quick]
        [--part scaling|scaling_default|settled|settled_default|saturation|scenes|whole|
                hessian]
"""

from __future__ import annotations

import argparse
import math
import pickle
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # experiments/: _common
from _common import SHARP_CONTACT, best_of, write_csv  # noqa: E402
from numba import njit  # noqa: E402

from bathprint import Simulation, simulate
from bathprint.core.effects._segment_geometry import segment_distance
from bathprint.core.effects.contact import min_separation_for
from bathprint.core.layout import DRAG_MU_S

MM = 1e-3
R_FIL = 0.205 * MM  # 22G
SPACING = 0.3 * MM


def coil_stack(
    n: int, contact: bool, gap: float = 1.5, extra: dict | None = None, law: dict | None = None
) -> Simulation:
    """``gap``: the pitch in sums of the two radii (2r); ``extra``: more scene overrides;
    ``law``: contact's law, SHARP_CONTACT (the law the stacks were measured with) unless
    given (``{}``: contact's defaults). The stack
    stands 50 mm below the bath's surface, or lower when it is taller than 45 mm (so that its
    top stays 5 mm under the surface: above it, where the bath gives no buoyancy, the upper
    turns would weigh on the lower ones)."""
    radius, pitch = 3 * MM, gap * 2 * R_FIL
    dphi = SPACING / math.hypot(radius, pitch / (2 * math.pi))
    phi = dphi * np.arange(n)
    height = pitch * phi[-1] / (2 * math.pi)
    base = min(-50 * MM, -height - 5 * MM)
    pts = np.column_stack(
        [radius * np.cos(phi), radius * np.sin(phi), base + pitch * phi / (2 * math.pi)]
    )
    effects = ["elasticity", "drag", "gravity"] + (["contact"] if contact else [])
    return Simulation.from_points(
        pts,
        "drag_coiling_22G",
        {"effects": effects, "duration_s": 1e3, **law_or_sharp(law), **(extra or {})},
        relaxed=True,
    )


def law_or_sharp(law: dict | None) -> dict:
    """``law``, or SHARP_CONTACT where it is None."""
    return SHARP_CONTACT if law is None else law


def pair_counts(sim: Simulation) -> dict[str, float]:
    """The contact list of ``sim`` now: candidate and near pairs per node."""
    contact = sim.ws.contact
    n = sim.n_nodes
    return {
        "pairs_per_segment": int(contact.count[0]) / n,
        "near_per_segment": int(contact.memory[0]["n_near"]) / n,
    }


WARM_UP_S = 2e-3  # the stack's first relaxation, timed apart from the window


def scaling(
    sizes: list[int],
    duration: float,
    gap: float,
    preconditioner: str = "band",
    warm_up: float = WARM_UP_S,
    max_step: float = 0.0,
    law: dict | None = None,
) -> list[dict]:
    """The stack of N nodes at pitch ``gap`` with and without contact (with
    ``numerics.preconditioner``, steps of at most ``max_step`` if it is > 0, and contact's
    ``law``, as :func:`coil_stack`), best of 3:
    its first ``warm_up`` seconds (a stack drawn pressed into contact everywhere relaxes:
    wall time and steps apart), then ``duration`` more: cost per step and per node-step,
    Newton and Krylov iterations, pairs, over that window."""
    rows = []
    extra: dict = {"numerics.preconditioner": preconditioner}
    if max_step > 0.0:
        extra["numerics.max_step_s"] = max_step
    for n in sizes:
        out = {
            "pitch_over_contact_distance": gap,
            "nodes": n,
            "law": "sharp" if law is None else "default",
            "preconditioner": preconditioner,
            "warm_up_s": warm_up,
            "window_s": duration,
            "max_step_s": max_step,
        }
        for contact in (False, True):
            key = "contact" if contact else "none"
            base = coil_stack(n, contact, gap, extra, law)
            base.advance(1e-3)  # compile

            warmed = [coil_stack(n, contact, gap, extra, law) for _ in range(3)]
            warm_walls = []
            for s in warmed:
                t0 = time.perf_counter()
                s.advance(warm_up)
                warm_walls.append(time.perf_counter() - t0)
            out[f"warm_up_wall_s_{key}"] = min(warm_walls)
            out[f"warm_up_steps_{key}"] = warmed[0].counts()["steps"]
            start = {id(s): s.counts() for s in warmed}
            sims = iter(warmed)
            last = {}

            def run(sims=sims, last=last, t_end=warm_up + duration) -> None:
                s = next(sims)
                s.advance(t_end)
                last["sim"] = s

            total = best_of(run, 3)
            end = last["sim"].counts()
            c = {k: end[k] - start[id(last["sim"])][k] for k in end}
            wall = total / max(c["steps"], 1)
            out[f"wall_s_{key}"] = total
            out[f"us_per_step_{key}"] = 1e6 * wall
            out[f"ns_per_node_step_{key}"] = 1e9 * wall / n
            out[f"newton_per_step_{key}"] = c["newton_iterations"] / max(c["steps"], 1)
            out[f"us_per_newton_node_{key}"] = 1e6 * wall / out[f"newton_per_step_{key}"] / n
            if contact:
                mem = last["sim"].ws.contact.memory[0]
                out["krylov_per_newton"] = c["krylov_iterations"] / max(c["newton_iterations"], 1)
                out.update(pair_counts(last["sim"]))
                out["hash_builds_per_step"] = int(mem["builds"]) / max(c["steps"], 1)
        out["ratio"] = out["us_per_step_contact"] / out["us_per_step_none"]
        out["ratio_wall"] = out["wall_s_contact"] / out["wall_s_none"]
        rows.append(out)
        print(
            f"pitch {gap:g} delta, {preconditioner}, N = {n:>6}: "
            f"{out['us_per_step_none']:9.1f} us/step without, "
            f"{out['us_per_step_contact']:9.1f} with contact (x{out['ratio']:.2f}; "
            f"{out['ns_per_node_step_contact']:6.0f} ns per node-step; Newton per step "
            f"{out['newton_per_step_none']:.1f} / {out['newton_per_step_contact']:.1f}; "
            f"{out['krylov_per_newton']:.2f} Krylov per Newton; per segment "
            f"{out['pairs_per_segment']:.1f} candidate, {out['near_per_segment']:.1f} near pairs; "
            f"{out['hash_builds_per_step']:.2f} hash builds per step)"
        )
    return rows


@njit(cache=True)
def _min_gap(pos, n, radius, min_sep) -> float:
    best = np.inf
    for i in range(n - 1):
        for j in range(i + min_sep + 1, n - 1):
            best = min(best, segment_distance(pos, i, i + 1, j, j + 1) / (2 * radius))
    return best


def scenes(durations: dict[str, float]) -> list[dict]:
    rows = []
    for scene, duration in durations.items():
        out = {"scene": scene, "duration_s": duration}
        for contact in (False, True):
            base = Simulation(scene).scene
            effects = [e for e in base.effects if e != "contact"] + (["contact"] if contact else [])
            over = {"duration_s": duration, "outputs.plot": False, "effects": effects}
            simulate(scene, {**over, "duration_s": 0.01})  # compile this combination
            t0 = time.perf_counter()
            res = simulate(scene, over)
            wall = time.perf_counter() - t0
            s = res.summary
            r = float(res.material[0, 2])
            spacing = s["numerics"]["node_spacing_mm"] * MM
            sep = min_separation_for(2 * r, spacing)
            gap = min(
                _min_gap(np.ascontiguousarray(f).ravel(), len(f), r, sep) for f in res.frames[1:]
            )
            key = "contact" if contact else "none"
            out[f"wall_s_{key}"] = wall
            out[f"steps_{key}"] = s["steps"]
            out[f"newton_{key}"] = s["newton_iterations"]
            out[f"min_gap_{key}"] = gap
            if contact:
                out["krylov_per_newton"] = s["krylov_iterations"] / max(s["newton_iterations"], 1)
                out["contact_retries"] = s["contact_rejections"]
        out["ratio"] = out["wall_s_contact"] / out["wall_s_none"]
        rows.append(out)
        print(
            f"{scene:>22} {duration:g} s: {out['wall_s_none']:.2f} s without contact, "
            f"{out['wall_s_contact']:.2f} s with (x{out['ratio']:.2f}); Krylov per Newton "
            f"{out['krylov_per_newton']:.2f}; smallest gap / contact distance "
            f"{out['min_gap_none']:.3f} without, {out['min_gap_contact']:.3f} with"
        )
    return rows


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--quick", action="store_true", help="smaller sizes and shorter runs")
    p.add_argument(
        "--part",
        choices=(
            "all",
            "scaling",
            "scaling_default",
            "settled",
            "settled_default",
            "saturation",
            "scenes",
            "whole",
            "hessian",
        ),
        default="all",
    )
    args = p.parse_args()
    if args.part in ("all", "scaling"):
        scaling_part(args.quick)
    if args.part in ("all", "scaling_default"):
        scaling_default_part(args.quick)
    if args.part in ("all", "settled"):
        settled_part(args.quick)
    if args.part in ("all", "settled_default"):
        settled_part(args.quick, law={})
    if args.part in ("all", "saturation"):
        saturation_part(args.quick)
    if args.part in ("all", "scenes"):
        scenes_part(args.quick)
    if args.part in ("all", "whole"):
        whole_part(args.quick)
    if args.part in ("all", "hessian"):
        hessian_part(args.quick)


def scaling_part(quick: bool) -> None:
    apart = [100, 300, 1000] if quick else [100, 300, 1000, 3000, 10000]
    touching = [100, 300] if quick else [100, 300, 1000, 3000, 10000]
    duration = 5e-3 if quick else 2e-2
    print("cost per step against N (a coil stack sinking, adaptive steps):")
    rows = scaling(apart, duration, 1.5) + scaling(touching, duration, 0.98)
    rows += scaling(touching, duration, 0.98, "axial_coarse")
    write_csv("contact_scaling", rows)


def scaling_default_part(quick: bool) -> None:
    """The pressed stacks of ``--part scaling`` (pitch 0.98 (2r)) with contact's default law,
    the soft onset of 0.2 delta from 1.02 (r_A + r_B): the turns start 0.04 delta inside it,
    where its stiffness is a fifth of the full one."""
    touching = [100, 300] if quick else [100, 300, 1000, 3000, 10000]
    duration = 5e-3 if quick else 2e-2
    print("cost per step against N, pressed stacks, contact's default law:")
    rows = scaling(touching, duration, 0.98, law={})
    rows += scaling(touching, duration, 0.98, "axial_coarse", law={})
    write_csv("contact_scaling_default", rows)


SETTLED_WARM_UP_S = 0.02  # a pressed stack of 10^4 nodes relaxes over about 20 ms
SETTLED_MAX_STEP_S = 2.5e-4  # the same steps at every N


def settled_part(quick: bool, law: dict | None = None) -> None:
    """The pressed stacks after they have relaxed (SETTLED_WARM_UP_S), at steps of at most
    SETTLED_MAX_STEP_S: the same physics and steps at every N, so the cost per node-step
    shows how the work of a step grows with N. ``law``: as :func:`coil_stack` (``{}``,
    ``--part settled_default``: contact's default law)."""
    touching = [300, 1000] if quick else [300, 1000, 3000, 10000]
    duration = 5e-3 if quick else 2e-2
    print(
        f"cost per step against N, pressed stacks after {SETTLED_WARM_UP_S * 1e3:g} ms, "
        f"steps of at most {SETTLED_MAX_STEP_S * 1e3:g} ms:"
    )
    rows = []
    for preconditioner in ("band", "axial_coarse"):
        rows += scaling(
            touching, duration, 0.98, preconditioner, SETTLED_WARM_UP_S, SETTLED_MAX_STEP_S, law
        )
    write_csv("contact_scaling_settled" + ("" if law is None else "_default"), rows)


SATURATION_SIZES = (300, 1000, 3000, 10000, 30000, 100000)
SATURATION_STEPS_S = (2.5e-4, 6.25e-5)  # the window's largest step: the settled one, and 1/4
SATURATION_WINDOW_S = 5e-3
SATURATION_REPEATS = 2  # windows timed per variant (the best counts), from copies of one state
COIL_RADIUS = 3 * MM  # coil_stack's


def stack_turns(n: int, gap: float) -> float:
    """The turns of ``coil_stack(n, _, gap)``."""
    pitch = gap * 2 * R_FIL
    return (n - 1) * SPACING / math.hypot(COIL_RADIUS, pitch / (2 * math.pi)) / (2 * math.pi)


def stack_coupling(sim: Simulation, step_s: float, turns: float) -> dict[str, float]:
    """A model of a pressed, overdamped, free stack's Newton matrix A with its band B (the
    banded LU) as GMRES's preconditioner, and the bound on GMRES's iterations it gives.

    Per length of turn k, its vertical displacement u_k meets the drag of a step h,
    zeta_n / h (zeta_n = 2 mu_s, the local drag law's normal coefficient), and the
    penalty's stiffness k_c (``contact.stiffness_pa``; its largest, reached past the soft
    onset) towards the turns above and below, which are off the band: B holds zeta_n / h +
    2 k_c on the diagonal (zeta_n / h + k_c at the free top and bottom turns) and A = B -
    k_c S (S the shifts up and down a turn). The stack's translation stretches no contact,
    so B^-1 A has an eigenvalue near 1 / (1 + 2 a), a = k_c h / zeta_n, at every height: its
    condition number kappa (computed here for round(T) >= 2 turns) is close to 1 + 4 a
    from a few turns on. With A and B symmetric positive definite, GMRES preconditioned by
    B reduces the residual, in B^-1's norm, by eps within 1/2 sqrt(kappa) ln(2 / eps)
    iterations (the Chebyshev bound; the solver's 2-norm adds up to sqrt(kappa(B)) inside
    the logarithm), and within as many as B^-1 A has distinct eigenvalues (T for these
    modes): ``krylov_bound`` = min(T, 1/2 sqrt(kappa) ln(2 / eps)), eps the scene's
    ``numerics.krylov_tolerance``, which stops growing beyond ``crossover_turns``. The
    simulator's matrix is neither symmetric nor always definite: an estimate of the shape,
    not a guarantee."""
    p = sim.model.params[0]
    if int(p["drag_model"]) != DRAG_MU_S:
        raise ValueError(f"drag model {int(p['drag_model'])}: the model needs the local law")
    zeta_n = 2.0 * float(p["mu_s"])  # Pa s: normal drag per length and speed
    a = float(p["contact_stiffness"]) * step_s / zeta_n
    n = max(2, round(turns))
    diag = np.full(n, 1.0 + 2.0 * a)  # in units of zeta_n / h
    diag[[0, -1]] = 1.0 + a
    scale = 1.0 / np.sqrt(diag)
    sym = np.diag(np.ones(n)) - a * np.outer(scale, scale) * (np.eye(n, k=1) + np.eye(n, k=-1))
    eig = np.linalg.eigvalsh(sym)  # of B^-1/2 A B^-1/2, similar to B^-1 A
    kappa = float(eig[-1] / eig[0])
    reduction = math.log(2.0 / float(p["krylov_tolerance"]))
    chebyshev = 0.5 * math.sqrt(kappa) * reduction
    return {
        "drag_normal_pa_s": zeta_n,
        "stiffness_over_drag": a,
        "kappa_model": kappa,
        "krylov_bound": min(float(n), chebyshev),
        "crossover_turns": 0.5 * math.sqrt(1.0 + 4.0 * a) * reduction,
    }


def saturation_rows(
    sizes: Sequence[int], steps: Sequence[float], warm_up: float, window: float, repeats: int
) -> list[dict]:
    """Pressed stacks (0.98 delta, banded LU) relaxed for ``warm_up`` at steps of at most
    steps[0], then ``window`` more at each largest step of ``steps`` (set in the compiled
    parameter record of pickled copies of the relaxed state; best of ``repeats``), with and
    without contact: Krylov iterations per Newton iteration against the model's condition
    number and iteration bound (:func:`stack_coupling`, with h the window's mean step),
    cost per node-step, and the candidate and near pairs per segment and blocks off the band
    per node at the window's end."""
    rows = []
    for n in sizes:
        turns = stack_turns(n, 0.98)
        states = {}
        for contact in (False, True):
            sim = coil_stack(n, contact, 0.98, {"numerics.max_step_s": steps[0]})
            sim.advance(warm_up)
            states[contact] = pickle.dumps(sim)
        for step in steps:
            out: dict = {"nodes": n, "turns": turns, "max_step_s": step, "window_s": window}
            for contact in (False, True):
                key = "contact" if contact else "none"
                best = math.inf
                for _ in range(repeats):
                    sim = pickle.loads(states[contact])
                    sim.model.params[0]["max_step"] = step
                    t_start, start = sim.t, sim.counts()
                    t0 = time.perf_counter()
                    sim.advance(t_start + window)
                    wall = time.perf_counter() - t0
                    if wall < best:
                        best = wall
                        end = sim.counts()
                        c = {k: end[k] - start[k] for k in end}
                n_steps = max(c["steps"], 1)
                out[f"steps_{key}"] = n_steps
                out[f"ns_per_node_step_{key}"] = 1e9 * best / n_steps / n
                out[f"newton_per_step_{key}"] = c["newton_iterations"] / n_steps
                if contact:
                    out.update(pair_counts(sim))
                    out["off_band_blocks_per_node"] = int(sim.ws.cpl.count[0]) / n
                    out["merged_blocks_per_node"] = max(int(sim.ws.cpl.merged[0]), 0) / n
                    out["mean_step_s"] = window / n_steps
                    out["krylov_per_newton"] = c["krylov_iterations"] / max(
                        c["newton_iterations"], 1
                    )
                    out.update(stack_coupling(sim, out["mean_step_s"], turns))
            out["ratio"] = out["ns_per_node_step_contact"] / out["ns_per_node_step_none"]
            out["krylov_over_bound"] = out["krylov_per_newton"] / out["krylov_bound"]
            rows.append(out)
            print(
                f"N = {n:>6} ({turns:5.1f} turns), steps {1e3 * out['mean_step_s']:.4f} ms: "
                f"Krylov per Newton {out['krylov_per_newton']:.2f} (model bound "
                f"{out['krylov_bound']:.1f}); {out['ns_per_node_step_none']:.0f} / "
                f"{out['ns_per_node_step_contact']:.0f} ns per node-step without / with "
                f"(x{out['ratio']:.2f})",
                flush=True,
            )
    return rows


def saturation_part(quick: bool) -> None:
    """Where the Krylov iterations of a pressed stack stop growing with its height."""
    sizes = (300, 1000) if quick else SATURATION_SIZES
    print(
        f"pressed stacks after {SETTLED_WARM_UP_S * 1e3:g} ms, {SATURATION_WINDOW_S * 1e3:g} ms "
        "windows: Krylov iterations against the stack's height and step"
    )
    rows = saturation_rows(
        sizes, SATURATION_STEPS_S, SETTLED_WARM_UP_S, SATURATION_WINDOW_S, SATURATION_REPEATS
    )
    print("wrote", write_csv("contact_saturation", rows))


def scenes_part(quick: bool) -> None:
    durations = (
        {"drag_coiling_22G": 1.0, "period_doubling_22G": 0.1}
        if quick
        else {"drag_coiling_22G": 4.0, "period_doubling_22G": 0.5}
    )
    print("the coiling scenes with and without contact (same process):")
    print("wrote", write_csv("contact_scenes", scenes(durations)))


def contact_scenes() -> list[str]:
    """The built-in scenes whose effects list ``contact``."""
    from bathprint.core.scene import builtin_scene_names

    return [n for n in builtin_scene_names() if "contact" in Simulation(n).scene.effects]


def whole_runs(
    scenes: list[str], fraction: float = 1.0, overrides: dict | None = None, repeats: int = 1
) -> list[dict]:
    """Each scene for ``fraction`` of its own duration (with ``overrides``; the best wall
    time of ``repeats``): wall time, steps, Newton iterations and failures, the smallest gap
    between non-adjacent segments over every saved frame (in contact distances r_i + r_j),
    Krylov iterations and contact retries."""
    rows = []
    for scene in scenes:
        duration = fraction * Simulation(scene).scene.duration_s
        over = {"duration_s": duration, "outputs.plot": False, **(overrides or {})}
        simulate(scene, {**over, "duration_s": 1e-3})  # compile
        wall = math.inf
        for _ in range(repeats):
            t0 = time.perf_counter()
            res = simulate(scene, over)
            wall = min(wall, time.perf_counter() - t0)
        s = res.summary
        r = float(res.material[0, 2])
        sep = min_separation_for(2 * r, s["numerics"]["node_spacing_mm"] * MM)
        gaps = [_min_gap(np.ascontiguousarray(f).ravel(), len(f), r, sep) for f in res.frames[1:]]
        row = {
            "scene": scene,
            "duration_s": duration,
            "frames": len(gaps),
            "wall_s": wall,
            "steps": s["steps"],
            "newton_iterations": s["newton_iterations"],
            "newton_failures": s["newton_failures"],
            "min_gap_ratio": min(gaps),
            "frames_below_0.9": sum(g < 0.9 for g in gaps),
            "krylov_iterations": s["krylov_iterations"],
            "contact_rejections": s["contact_rejections"],
        }
        rows.append(row)
        print(
            f"{scene:>24} {duration:g} s: {wall:.1f} s wall, {row['steps']} steps, smallest gap "
            f"{row['min_gap_ratio']:.3f} over {len(gaps)} frames, Krylov {row['krylov_iterations']}"
        )
    return rows


def whole_part(quick: bool) -> None:
    print("every built-in scene with contact, its whole run:")
    rows = whole_runs(contact_scenes(), 0.05 if quick else 1.0)
    print("wrote", write_csv("contact_whole_runs", rows))


HESSIANS = ("exact", "gauss_newton")  # contact.hessian


def hessian_rows(scenes: list[str], fraction: float, repeats: int) -> list[dict]:
    """Every scene's run with each ``contact.hessian`` (best of ``repeats``), and its wall time
    against the default's (the exact Hessian's), in the same process."""
    rows = []
    for scene in scenes:
        base = None
        for hessian in HESSIANS:
            over = {**SHARP_CONTACT, "contact.hessian": hessian}
            (row,) = whole_runs([scene], fraction, over, repeats)
            base = base or row["wall_s"]
            rows.append({"hessian": hessian, **row, "wall_ratio": row["wall_s"] / base})
    return rows


def hessian_part(quick: bool) -> None:
    print("every built-in scene with contact, exact and Gauss-Newton Hessian:")
    rows = hessian_rows(contact_scenes(), 0.05 if quick else 1.0, 1 if quick else 2)
    print("wrote", write_csv("contact_hessian", rows))


if __name__ == "__main__":
    main()
