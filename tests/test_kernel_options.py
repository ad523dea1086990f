"""Kernels compiled without reference counting (bathprint.core.jit.KERNEL) never return an
array (a caller that counts would release it once too often), and their results are the
same with and without it."""

from __future__ import annotations

import importlib
import pkgutil

import numpy as np
import pytest
from numba import types
from numba.core.registry import CPUDispatcher

import bathprint.core
from bathprint import Simulation
from bathprint.core.jit import KERNEL

# short runs that compile the kernels of every effect, integrator and solver path
RUNS = [
    ("paper_simulation", {"duration_s": 0.02}),
    ("rope_coiling_18G", {"duration_s": 0.02}),  # floor
    ("drag_coiling_22G", {"duration_s": 0.01}),  # contact, off-band solver
    ("cantilever_water", {"duration_s": 0.002, "effects": ["elasticity", "drag", "gravity",
                          "inertia"], "numerics.integrator": "sdirk4",
                          "numerics.time_step_s": 1e-3}),
    ("cantilever_water", {"duration_s": 1e-6, "numerics.integrator": "explicit",
                          "numerics.time_step_s": 2.5e-10}),
    ("gelation_coiling_22G", {"duration_s": 0.02, "numerics.freeze_beyond_mm": 5}),
    ("drag_coiling_22G", {"duration_s": 0.01, "effects": ["elasticity", "drag", "gravity",
                          "gelation"], "gelation.model": "surface"}),
    ("drag_coiling_22G", {"duration_s": 0.005, "effects": ["elasticity", "drag", "gravity",
                          "hydrodynamics"], "hydrodynamics.coupling": "implicit"}),
    ("paper_simulation", {"duration_s": 0.01, "effects": ["elasticity", "drag",
                          "viscosity"]}),
    ("cantilever_water", {"duration_s": 0.01, "effects": ["elasticity", "drag", "end_load"],
                          "end_load.force_n": [1e-7, 0, 0]}),
]  # fmt: skip


def _kernels() -> dict[str, CPUDispatcher]:
    out = {}
    for info in pkgutil.walk_packages(bathprint.core.__path__, "bathprint.core."):
        module = importlib.import_module(info.name)
        for name, obj in vars(module).items():
            if isinstance(obj, CPUDispatcher) and obj.__module__ == info.name:
                out[f"{info.name}.{name}"] = obj
    return out


def _return_types(dispatcher: CPUDispatcher) -> list[types.Type]:
    """Return types of a kernel's compiled versions: those of this process, else those in
    numba's on-disk cache (a caller loaded from the cache holds its callees' code, so the
    callees themselves are not loaded; their cache index lists the signatures)."""
    if not dispatcher.signatures and dispatcher._cache is not None:
        for key in dispatcher._cache._cache_file._load_index():
            dispatcher.compile(key[0])  # from the cache
    return [dispatcher.overloads[s].signature.return_type for s in dispatcher.signatures]


def _holds_array(t: types.Type) -> bool:
    if isinstance(t, types.Array):
        return True
    if isinstance(t, types.BaseTuple):
        return any(_holds_array(x) for x in t.types)
    return False


def test_kernels_without_reference_counting_return_no_arrays() -> None:
    for scene, over in RUNS:
        sim = Simulation(scene, over)
        sim.advance(sim.scene.duration_s)
    kernels = _kernels()
    uncounted = {k: d for k, d in kernels.items() if d.targetoptions.get("_nrt") is False}
    assert len(uncounted) > 100, len(uncounted)  # the option reaches the kernels
    assert KERNEL["_nrt"] is False
    checked = 0
    for name, dispatcher in uncounted.items():
        for ret in _return_types(dispatcher):
            assert not _holds_array(ret), f"{name} returns {ret}; compile it with NRT"
            checked += 1
    # the kernels the runs above reach, compiled here or before; helpers that exist only
    # inside their callers (inlined, or compiled with them) have no versions of their own
    assert checked >= 90, (checked, len(uncounted))


def test_same_numbers_with_and_without_reference_counting() -> None:
    """A kernel compiled both ways from the same source gives the same bits."""
    from numba import njit

    from bathprint.core.effects import _segment_geometry as geometry

    counted = njit(cache=False)(geometry.closest_params.py_func)
    rng = np.random.default_rng(0)
    for _ in range(50):
        pos = rng.normal(size=12)
        assert geometry.closest_params(pos, 0, 1, 2, 3) == counted(pos, 0, 1, 2, 3)


def test_record_kernels_have_no_python_wrapper_and_a_python_call_runs_their_twin() -> None:
    """Kernels that take the records are compiled without numba's CPython wrapper; a call
    from Python runs a twin compiled with one, which computes the same numbers."""
    from bathprint.core import layout
    from bathprint.core.assemble import assemble
    from bathprint.core.effects import elasticity
    from bathprint.core.jit import KernelDispatcher

    callees = {k: d for k, d in _kernels().items() if isinstance(d, KernelDispatcher)}
    assert len(callees) >= 30, len(callees)
    assert all(d.targetoptions.get("no_cpython_wrapper") for d in callees.values())
    assert all(d.targetoptions.get("_nrt") is False for d in callees.values())
    sim = Simulation("paper_simulation", {"duration_s": 0.01})
    sim.advance(0.01)  # a bent filament: every term of the elastic force is non-trivial
    calls, energies = np.zeros_like(sim.calls), np.zeros_like(sim.energies)
    assemble(*sim.kernel_inputs(), calls, energies)  # calls the callees
    energy = elasticity.accumulate(*sim.kernel_inputs())  # the twin of the effect's kernel
    expected = energies[layout.EFFECT_NAMES.index("elasticity")]
    assert abs(expected) > 0.0
    assert energy == pytest.approx(expected, rel=1e-12, abs=0.0)
    assert "_python_twin" in elasticity.accumulate.__dict__
