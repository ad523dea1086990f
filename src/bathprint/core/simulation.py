"""The state of a filament and the stepper that moves it: :class:`Simulation`.

Node order runs from the free end (node 0, the oldest material) to the needle tip
(node n-2) and a ghost node inside the needle (node n-1) that clamps the tangent.
All arrays are preallocated with spare capacity and grown (doubled) between calls.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from numba.core.typing.typeof import Purpose, typeof

from bathprint.core import layout as L
from bathprint.core import records
from bathprint.core.assemble import assemble
from bathprint.core.extrusion import (
    extruded_length,
    flow_rate,
    flow_step,
    material_row,
    needle_state,
    set_boundary,
)
from bathprint.core.integrators import N_VECS, V_ACC, V_POS0, V_VEL0, advance, explicit_step
from bathprint.core.model import Model, compile_model
from bathprint.core.scene import Scene, load_scene
from bathprint.errors import SimulationError


def _perpendicular(d: np.ndarray) -> np.ndarray:
    axis = np.array([1.0, 0.0, 0.0]) if abs(d[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(d, axis)
    return u / np.linalg.norm(u)


#: compiled entry points of :func:`advance`, by :func:`_layout_key` of its arguments
_ENTRY_POINTS: dict[tuple, Any] = {}


def _layout_key(value: Any) -> Any:
    """What numba's type of ``value`` depends on, cheaply: the class and children of a
    record (named tuple), each array's dtype, dimensions, contiguity, writeability and
    alignment, a scalar's class. Equal keys mean equal numba types."""
    if isinstance(value, np.ndarray):
        f = value.flags
        return (value.dtype, value.ndim, f.c_contiguous, f.f_contiguous, f.writeable, f.aligned)
    if isinstance(value, tuple):
        return (type(value), tuple(_layout_key(v) for v in value))
    return type(value)


class Simulation:
    """A running simulation of one scene.

    >>> sim = Simulation("paper_simulation", overrides={"duration_s": 0.5})
    >>> sim.advance(0.1)           # integrate to t = 0.1 s
    >>> sim.centerline().shape     # (n, 3) node positions, free end first, needle tip last
    """

    def __init__(
        self, scene: str | Path | Scene | dict, overrides: dict[str, Any] | None = None
    ) -> None:
        self.scene = load_scene(scene, overrides)
        self.model: Model = compile_model(self.scene)
        self._init_state()

    # ------------------------------------------------------------------ state
    def _capacity_estimate(self, n0: int) -> int:
        m = self.model
        s_end = extruded_length(m.flow, m.flow_cum, m.needle_area, self.scene.duration_s)
        return int(n0 + 1.2 * max(s_end, 0.0) / m.node_spacing + 16)

    def _init_state(self) -> None:
        m = self.model
        sc = self.scene
        dl = m.node_spacing
        length0 = sc.initial.length_mm * 1e-3 or 2.0 * dl
        n_seg = max(1, int(math.floor(length0 / dl + 1e-9)))
        seg_len = length0 / n_seg
        n_nodes = n_seg + 2  # free nodes, tip, ghost
        cap = max(64, self._capacity_estimate(n_nodes))
        self._alloc(cap)
        p = np.empty(3)
        d = np.empty(3)
        v = np.empty(3)
        needle_state(m.needle, 0.0, p, d, v)
        perp = _perpendicular(d)
        amp = sc.initial.perturbation_mm * 1e-3
        pos = self.pos.reshape(-1, 3)
        # a straight rod, or one bent in the first clamped-free mode shape
        # w(s) = amp (1 - cos(pi s / 2 L)), built segment by segment from the tip so that
        # every segment keeps its rest length (no stretching transient at t = 0)
        pos[n_seg] = p
        for i in range(n_seg - 1, -1, -1):
            s_mid = length0 - (i + 0.5) * seg_len  # arclength from the tip
            slope = amp * 0.5 * math.pi / length0 * math.sin(0.5 * math.pi * s_mid / length0)
            angle = math.atan(slope)
            pos[i] = pos[i + 1] + seg_len * (math.cos(angle) * d + math.sin(angle) * perp)
        for i in range(n_seg + 1):
            self.node_s[i] = -(length0 - i * seg_len)
        row = np.empty(L.N_MAT)
        qo, qi = flow_rate(m.flow, 0.0)
        phi0 = qi / (qo + qi) if qo + qi > 0 else 0.0
        material_row(phi0, -sc.initial.age_s, 0.0, d, m.p, row)
        self.seg_mat[: n_seg + 1] = row
        self.seg_rest[:n_seg] = seg_len
        self.istate[:] = (n_nodes, 0, 0)
        h0 = sc.numerics.time_step_s or min(sc.numerics.max_step_s, 1e-4)
        self.fstate[:] = (0.0, h0)
        if m.p.inertial:  # the stub leaves the needle with the jet: at the exit speed along d
            u = (qo + qi) / m.needle_area
            vel = self.vel.reshape(-1, 3)
            vel[: n_seg + 1] = v + u * d
        set_boundary(m.record, self._rod(), 0.0, self.ws.scratch)
        if not m.p.inertial:
            self._consistent_velocity()
        self.initial_volume = float(np.sum(self.seg_rest[:n_seg]) * m.needle_area)
        self.initial_length = float(length0)

    def _consistent_velocity(self) -> None:
        """Overdamped scenes start with the velocity the forces give (D v = F), not zero,
        so that error estimates that use the previous velocity are right from step one."""
        m = self.model
        n3 = 3 * self.n_nodes
        self.ws.vecs[V_POS0, :n3] = self.pos[:n3]
        self.ws.vecs[V_VEL0, :n3] = self.vel[:n3]
        explicit_step(m.record, self._rod(), self.state, self.ws, 0.0, 0.0)
        if not np.isfinite(self.vel[:n3]).all():
            self.vel[:n3] = 0.0

    def _alloc(self, cap: int) -> None:
        self.pos = np.zeros(3 * cap)
        self.vel = np.zeros(3 * cap)
        self.node_s = np.zeros(cap)
        self.seg_rest = np.zeros(cap)
        self.seg_mat = np.zeros((cap, L.N_MAT))
        old = getattr(self, "ws", None)
        hydro = bool(self.model.enabled[L.E_HYDRODYNAMICS])
        coarse = (
            records.COARSE_SPACING if self.scene.numerics.preconditioner == "axial_coarse" else 0
        )
        p = self.model.p
        self.ws = records.new_workspace(
            cap,
            N_VECS,
            off_band=self.off_band,
            hydro=hydro,
            coarse=coarse,
            velocity_couplings=p.contact_damping_time > 0 or p.contact_friction > 0,
        )
        if old is not None:  # what the stepper remembers survives a grow, but not the LU
            self.ws.solver[:] = old.solver
            self.ws.solver[0]["lu_valid"] = False
            self.ws.tail[:] = old.tail
            self.ws.contact.memory[:] = old.contact.memory
            self.ws.contact.memory[0]["built_nodes"] = -1  # its pairs are not carried over
            self.ws.hydro.memory[:] = old.hydro.memory  # (its flows are gone: re-evaluated)
            for flag in ("linearized", "u_valid", "next_valid"):
                self.ws.hydro.memory[0][flag] = False
        if not hasattr(self, "istate"):
            self.istate = np.zeros(3, dtype=np.int64)  # n_nodes, n_splits, n_frozen
            self.fstate = np.zeros(2)  # t, next step
            self.calls = np.zeros(L.N_EFFECTS, dtype=np.int64)
            self.counters = np.zeros(L.N_COUNTERS, dtype=np.int64)
            self.energies = np.zeros(L.N_EFFECTS)
            self.info = np.zeros(3)

    @property
    def off_band(self) -> bool:
        """True when the scene lists an effect that couples distant nodes (contact, or
        hydrodynamics with the implicit coupling): its linear systems are solved by GMRES,
        preconditioned by the band's LU, instead of by the banded LU alone."""
        m = self.model
        hydro = m.enabled[L.E_HYDRODYNAMICS] and m.p.hydro_coupling == L.HYDRO_IMPLICIT
        return bool(m.enabled[L.E_CONTACT] or hydro)

    def make_room(self) -> None:
        """Enlarge what a kernel found full (it returned ``STATUS_CAPACITY``): the node
        arrays when the rod fills them, else the room for couplings off the band and for
        contact pairs. :meth:`advance` calls it and goes on; so do replays of the time loop
        outside it (experiments/step_profile)."""
        if self.n_nodes + 2 > self.capacity:
            self._grow()
        else:
            self._grow_off_band()

    def _grow_off_band(self) -> None:
        """Double the room for couplings off the band and for contact pairs."""
        ws = self.ws
        cpl, cpl_filter, con = ws.cpl, ws.cpl_filter, ws.contact
        if cpl.count[0] > cpl.row.shape[0]:
            cpl = records.new_couplings(max(2 * cpl.row.shape[0], int(cpl.count[0]) + 16))
        if cpl_filter.count[0] > cpl_filter.row.shape[0]:
            cpl_filter = records.new_couplings(
                max(2 * cpl_filter.row.shape[0], int(cpl_filter.count[0]) + 16)
            )
        if con.count[0] > con.pairs.shape[0]:
            fresh = records.new_contact(
                self.capacity, max(2 * con.pairs.shape[0], int(con.count[0]))
            )
            fresh.memory[:] = con.memory
            con = fresh
        self.ws = ws._replace(cpl=cpl, cpl_filter=cpl_filter, contact=con)

    @property
    def state(self) -> records.State:
        """The state record the kernels take (views of this simulation's arrays)."""
        return records.State(
            self.pos,
            self.vel,
            self.node_s,
            self.seg_rest,
            self.seg_mat,
            self.istate,
            self.fstate,
            self.counters,
            self.calls,
            self.energies,
            self.info,
        )

    def _rod(self) -> records.Rod:
        """The whole rod (frozen tail included) as the kernels see it."""
        return records.Rod(
            self.pos,
            self.vel,
            self.ws.vecs[V_ACC],
            self.n_nodes,
            self.node_s,
            self.seg_rest,
            self.seg_mat,
        )

    def __getstate__(self) -> dict:
        """Pickled and copied without the resolved kernel entry point (a compiled function)."""
        state = self.__dict__.copy()
        state.pop("_advance_entry", None)
        return state

    def __setstate__(self, state: dict) -> None:
        """Unpickle; a pickle of an older layout (flat parameter and work arrays) is refused
        with the reason, instead of running kernels on misread arrays."""
        if "ws" not in state:
            raise ValueError(
                "this Simulation was pickled by an older bathprint (flat parameter arrays); "
                "build it again from its scene"
            )
        self.__dict__.update(state)

    def _grow(self) -> None:
        n = self.n_nodes
        old = (self.pos, self.vel, self.node_s, self.seg_rest, self.seg_mat)
        self._alloc(2 * self.capacity)
        self.pos[: 3 * n] = old[0][: 3 * n]
        self.vel[: 3 * n] = old[1][: 3 * n]
        self.node_s[:n] = old[2][:n]
        self.seg_rest[:n] = old[3][:n]
        self.seg_mat[:n] = old[4][:n]

    # ------------------------------------------------------------------ properties
    @property
    def t(self) -> float:
        """Simulated time (s)."""
        return float(self.fstate[0])

    @property
    def n_nodes(self) -> int:
        """Nodes including the needle tip and the ghost node."""
        return int(self.istate[0])

    @property
    def n_frozen(self) -> int:
        """Nodes frozen at the free end (``numerics.freeze_beyond_mm``): out of the solve,
        translated with the first active node."""
        return int(self.istate[2])

    @property
    def capacity(self) -> int:
        return self.pos.shape[0] // 3

    @property
    def clamped(self) -> bool:
        """True while the filament hangs from the needle; False once released."""
        return bool(self.model.params[0]["clamped"])

    @property
    def n_segments(self) -> int:
        """Filament segments (the ghost segment inside the needle excluded)."""
        return self.n_nodes - 2 if self.clamped else self.n_nodes - 1

    def centerline(self) -> np.ndarray:
        """Filament node positions (m), free end first, needle tip last: shape (n, 3)."""
        return self.pos[: 3 * (self.n_segments + 1)].reshape(-1, 3).copy()

    def velocities(self) -> np.ndarray:
        """Node velocities (m/s) along the centreline."""
        return self.vel[: 3 * (self.n_segments + 1)].reshape(-1, 3).copy()

    def newest_material(self, length_m: float, n_points: int = 61) -> np.ndarray:
        """Positions (m) of the last ``length_m`` of material out of the needle, resampled at
        ``n_points`` evenly spaced material coordinates from the tip back: a comparison of
        two runs near the needle that does not depend on where their nodes fall."""
        x = self.centerline()
        s = self.node_s[: len(x)]
        q = s[-1] - np.linspace(0.0, length_m, n_points)
        return np.stack([np.interp(q, s, x[:, a]) for a in range(3)], axis=1)

    def material(self) -> np.ndarray:
        """Per-segment material records (columns: ``layout.MATERIAL_COLUMNS``)."""
        return self.seg_mat[: self.n_segments].copy()

    def rest_lengths(self) -> np.ndarray:
        """Rest length of each filament segment (m)."""
        return self.seg_rest[: self.n_segments].copy()

    @classmethod
    def from_points(
        cls,
        points_m: np.ndarray,
        scene: str | Path | Scene | dict = "paper_simulation",
        overrides: dict[str, Any] | None = None,
        relaxed: bool = False,
    ) -> Simulation:
        """A free filament (not attached to the needle, nothing extruded) through the given
        node positions (m, shape (n, 3)), at rest, its rest lengths those drawn. ``relaxed``:
        its natural curvature is the drawn one, so the shape carries no bending stress. The
        scene gives the material, the bath and the effects (``flow`` is set to zero)."""
        pts = np.asarray(points_m, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 3 or len(pts) < 3 or not np.isfinite(pts).all():
            raise ValueError(f"points_m: shape {pts.shape}; allowed: (n >= 3, 3) finite values")
        seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        if seg.min() <= 0.0:
            raise ValueError("points_m: two consecutive points coincide")
        spacing_mm = float(np.median(seg) * 1e3)
        over = {
            **(overrides or {}),
            "flow.q_outer_ml_min": 0.0,
            "flow.q_inner_ml_min": 0.0,
            "flow.schedule": [],
            "initial.length_mm": (len(pts) + 1) * spacing_mm,
            "numerics.node_spacing_mm": spacing_mm,
        }
        sim = cls(scene, over)
        sim.release()
        n = len(pts)
        sim.istate[0] = n
        sim.pos[:] = 0.0
        sim.pos[: 3 * n] = pts.ravel()
        sim.vel[:] = 0.0
        sim.seg_rest[:] = 0.0
        sim.seg_rest[: n - 1] = seg
        sim.seg_mat[n - 1 :] = 0.0
        if relaxed:
            from bathprint.core.effects.gelation import node_curvature

            kappa = np.zeros((n, 3))
            for i in range(1, n - 1):
                node_curvature(sim.pos, sim.seg_rest, i, kappa[i])
            kappa[0], kappa[-1] = kappa[1], kappa[-2]
            k0 = 0.5 * (kappa[:-1] + kappa[1:])
            sim.seg_mat[: n - 1, L.MAT_KAPPA_X : L.MAT_KAPPA_X + 3] = k0
        if not sim.model.p.inertial:
            sim._consistent_velocity()
        return sim

    def release(self) -> None:
        """Cut the filament from the needle: the ghost node goes, every node moves freely."""
        if not self.clamped:
            return
        self.model.p.clamped = False
        self.istate[2] = 0  # a released filament has no needle to measure from: all active
        ghost = self.n_nodes - 1
        self.pos[3 * ghost : 3 * ghost + 3] = 0.0
        self.vel[3 * ghost : 3 * ghost + 3] = 0.0
        self.seg_rest[ghost - 1 :] = 0.0
        self.seg_mat[ghost - 1 :] = 0.0
        self.istate[0] = ghost

    def set_flow(self, q_outer_m3_s: float, q_inner_m3_s: float = 0.0) -> None:
        """Set the flow rates (m^3/s) from now on (a step change; the API environments use).

        Past knots stay (birth times and inner fractions of the material already out are
        derived from them); the schedule is held constant after the new knot.
        """
        for name, q in (("q_outer_m3_s", q_outer_m3_s), ("q_inner_m3_s", q_inner_m3_s)):
            if not math.isfinite(q) or q < 0:
                raise ValueError(f"{name} = {q!r}; allowed: a finite number >= 0")
        if q_inner_m3_s > 0 and not self.model.p.inclusions:
            raise ValueError(f"q_inner_m3_s = {q_inner_m3_s!r} > 0 needs the 'inclusions' effect")
        phi_max = self.scene.inclusions.max_inner_fraction
        if q_inner_m3_s > phi_max / (1 - phi_max) * q_outer_m3_s * (1.0 + 1e-12):
            raise ValueError(
                f"q_inner_m3_s = {q_inner_m3_s!r} is more than the needle allows with "
                f"q_outer_m3_s = {q_outer_m3_s!r} (inner fraction at most {phi_max:g})"
            )
        m = self.model
        m.flow, m.flow_cum = flow_step(
            m.flow, m.flow_cum, m.needle_area, self.t, q_outer_m3_s, q_inner_m3_s
        )

    def set_inclusion_offset(self, offset: float) -> None:
        """Set the inclusions' offset Delta = (r1 - r2) / r, in [-1, 1], from now on."""
        if not math.isfinite(offset) or abs(offset) > 1:
            raise ValueError(f"offset = {offset!r}; allowed: a number in [-1, 1]")
        self.model.p.inclusion_offset = offset

    def inner_volume(self) -> float:
        """Inner-fluid volume in the printed filament (m^3), from the segments' records."""
        mat = self.material()
        return float(
            np.sum(
                self.rest_lengths()
                * math.pi
                * mat[:, L.MAT_RADIUS] ** 2
                * mat[:, L.MAT_INNER_FRACTION]
            )
        )

    def printed_volume(self) -> float:
        """Volume of gel out of the needle (m^3), from the segments' rest lengths."""
        return float(np.sum(self.rest_lengths() * math.pi * self.material()[:, L.MAT_RADIUS] ** 2))

    def counts(self) -> dict[str, int]:
        """Steps, rejected steps, Newton iterations, node births, Newton failures, Jacobian
        factorisations, GMRES iterations and stalls (couplings off the band only), steps
        retried by the self-contact bound, evaluations of the nonlocal flow (hydrodynamics)
        and Newton iterations whose update was damped (halved after a stall) so far."""
        c = self.counters
        return {
            "steps": int(c[L.C_STEPS]),
            "rejected_steps": int(c[L.C_REJECTED]),
            "newton_iterations": int(c[L.C_NEWTON_ITERATIONS]),
            "nodes_born": int(c[L.C_SPLITS]),
            "newton_failures": int(c[L.C_NEWTON_FAILURES]),
            "jacobians": int(c[L.C_FACTORIZATIONS]),
            "krylov_iterations": int(c[L.C_KRYLOV_ITERATIONS]),
            "krylov_failures": int(c[L.C_KRYLOV_FAILURES]),
            "contact_rejections": int(c[L.C_CONTACT_REJECTIONS]),
            "hydro_evaluations": int(self.ws.hydro.memory[0]["evaluations"]),
            "damped_newton_iterations": int(c[L.C_DAMPED_NEWTON]),
            "line_search_backtracks": int(c[L.C_BACKTRACKS]),
        }

    def effect_calls(self) -> dict[str, int]:
        """How often each effect's kernel has run (0 for effects the scene does not list)."""
        return {name: int(self.calls[k]) for k, name in enumerate(L.EFFECT_NAMES)}

    def energies_now(self) -> dict[str, float]:
        """Energy of each listed effect at the current state (J; drag and viscosity: their
        dissipation rates, W), over the whole filament (a frozen tail's lumped load is not
        added again)."""
        zero = np.zeros_like(self.vel)
        force = np.zeros_like(self.pos)
        calls = np.zeros_like(self.calls)
        energies = np.zeros_like(self.energies)
        tail = self.ws.tail.copy()
        tail[0]["on"] = False  # the tail's lumped load is not counted twice
        rod = records.Rod(
            self.pos, self.vel, zero, self.n_nodes, self.node_s, self.seg_rest, self.seg_mat
        )
        out = records.Out(
            force,
            self.ws.band2,
            tail,
            self.ws.scratch,
            self.ws.cpl_drop,
            self.ws.contact,
            rod,
            0,
            self.pos,
            self.ws.hydro,
        )
        stage = records.Stage(self.t, 1.0, 0.0, 0.0, False)
        assemble(self.model.record, rod, stage, out, calls, energies)
        return {n: float(energies[k]) for k, n in enumerate(L.EFFECT_NAMES) if calls[k]}

    def kernel_inputs(
        self,
        cx: float = 1.0,
        cv: float = 0.0,
        ca: float = 0.0,
        jacobian: bool = True,
        vel: np.ndarray | None = None,
        acc: np.ndarray | None = None,
    ) -> tuple[records.Model, records.Rod, records.Stage, records.Out]:
        """The records one force evaluation takes, at the current state (the whole rod), with
        fresh output arrays: for analyses, tests and benchmarks that call effect kernels
        (``effect.accumulate(*sim.kernel_inputs())``). ``vel``, ``acc``: flat arrays (m/s,
        m/s^2) in place of the state's velocities and zero accelerations."""
        n3 = self.pos.shape[0]
        rod = records.Rod(
            self.pos,
            self.vel if vel is None else vel,
            np.zeros(n3) if acc is None else acc,
            self.n_nodes,
            self.node_s,
            self.seg_rest,
            self.seg_mat,
        )
        out = records.Out(
            np.zeros(n3),
            np.zeros_like(self.ws.band),
            self.ws.tail.copy(),
            records.new_scratch(),
            records.new_couplings(16 * self.capacity),
            self.ws.contact,
            rod,
            0,
            self.pos,
            self.ws.hydro,
        )
        return self.model.record, rod, records.Stage(self.t, cx, cv, ca, jacobian), out

    def forces(
        self,
        cx: float = 1.0,
        cv: float = 0.0,
        ca: float = 0.0,
        jacobian: bool = True,
        vel: np.ndarray | None = None,
        acc: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Total force (N, flat) of the listed effects at the current state and, with
        ``jacobian``, the band of -(cx dF/dx + cv dF/dv + ca dF/da) over the free nodes."""
        model, rod, stage, out = self.kernel_inputs(cx, cv, ca, jacobian, vel, acc)
        assemble(model, rod, stage, out, np.zeros_like(self.calls), np.zeros_like(self.energies))
        return out.force, out.band

    # ------------------------------------------------------------------ stepping
    def advance(self, t_end: float, max_steps: int = 10**9) -> None:
        """Integrate to ``t_end`` (s). Raises :class:`SimulationError` on divergence."""
        if not math.isfinite(t_end):
            raise ValueError(f"t_end = {t_end!r} must be finite")
        release = self.scene.needle.release_s
        if self.clamped and release > 0.0 and t_end > release:
            if self.t < release:
                self.advance(release, max_steps)
                if self.t < release:
                    return  # step budget used up before the release
            self.release()
        m = self.model
        budget = max_steps
        while True:
            before = int(self.counters[L.C_STEPS])
            args = (m.record, self.state, self.ws, float(t_end), int(budget))
            status = self._advance_kernel(args)(*args)
            budget -= int(self.counters[L.C_STEPS]) - before
            if status == L.STATUS_OK:
                return
            if status == L.STATUS_CAPACITY:
                self.make_room()
                continue
            if status == L.STATUS_STEP_LIMIT:
                return
            self._raise(status)

    def _advance_kernel(self, args: tuple) -> Any:
        """The compiled :func:`~bathprint.core.integrators.advance` for these records.

        numba's dispatcher resolves the types of the nested records on every call (about
        13 us, most of a short call's cost, as an environment's control step makes); the
        types are fixed by the workspace, so they are resolved once per workspace (it is
        replaced when it grows) and the compiled entry point is called directly."""
        entry = self.__dict__.get("_advance_entry")
        if entry is not None and entry[0] is self.ws:
            return entry[1]
        # numba's typeof of the records (1-2 ms) is paid once per layout of their arrays,
        # not once per simulation: a key at least as fine as numba's types finds it again
        key = _layout_key(args)
        point = _ENTRY_POINTS.get(key)
        if point is None:
            sig = tuple(typeof(a, Purpose.argument) for a in args)
            compiled = advance.overloads.get(sig)
            if compiled is None:  # not compiled for these types yet: the dispatcher compiles
                return advance
            point = _ENTRY_POINTS[key] = compiled.entry_point
        self._advance_entry = (self.ws, point)
        return point

    def _raise(self, status: int) -> None:
        cause = L.STATUS_MESSAGES.get(status, f"status {status}")
        t, node, value = self.info
        detail = ""
        if status == L.STATUS_STRETCH:
            detail = f"strain {value:+.3g} beyond numerics.stretch_limit"
        elif status == L.STATUS_CONTACT:
            mem = self.ws.contact.memory[0]
            step = (
                f"fixed step {self.scene.numerics.time_step_s:g} s; use a smaller "
                "numerics.time_step_s"
                if self.scene.numerics.time_step_s > 0
                else f"step {self.fstate[1]:.3g} s, min step {self.scene.numerics.min_step_s:g} s"
            )
            detail = (
                f"segments {int(node)} and {int(value)} (from the free end) moved "
                f"{mem['ratio']:.3g} times what keeps them apart; {step}"
            )
        elif status in (L.STATUS_NEWTON, L.STATUS_ERROR, L.STATUS_STRAIN, L.STATUS_KRYLOV):
            detail = (
                f"integrator {self.scene.numerics.integrator}, "
                f"step {self.fstate[1]:.3g} s, min step {self.scene.numerics.min_step_s:g} s"
                if self.scene.numerics.time_step_s == 0
                else f"fixed step {self.scene.numerics.time_step_s:g} s"
            )
            if status == L.STATUS_KRYLOV:
                detail += self._strongest_coupling()
        raise SimulationError(cause, t, int(node), detail)

    def _strongest_coupling(self) -> str:
        """The node pair of the largest off-band block of the last Newton matrix (the
        contact pair or hydrodynamic coupling GMRES could not resolve), for the error."""
        cpl = self.ws.cpl
        count = min(int(cpl.count[0]), len(cpl.row))
        if count == 0:
            return "; no couplings off the band"
        norms = np.abs(cpl.block[:count]).reshape(count, 9).max(axis=1)
        k = int(np.argmax(norms))
        first = self.n_frozen  # the active system starts after the frozen tail
        return (
            f"; strongest coupling off the band: nodes {int(cpl.row[k]) + first} and "
            f"{int(cpl.col[k]) + first} (from the free end), |block| {norms[k]:.3g}, "
            f"of {count} blocks"
        )
