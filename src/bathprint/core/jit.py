"""The numba options of the simulator's kernels (``@njit(**KERNEL)``).

The kernels take records of many arrays (:mod:`bathprint.core.records`) and call one
another many times per step: the stages, every force evaluation and each of its effects,
the solves. With numba's reference counting (NRT) on, every such call increments and
decrements the count of every array its arguments hold, about 7 ns per array
(``python experiments/call_overhead/call_overhead.py``): an effect's call with its output record of
some 60 arrays costs about 0.5 us, which short steps of small rods pay many times.

The kernels allocate nothing (their arrays are the records' preallocated ones) and return
no arrays, so they need no reference counting, and are compiled without it
(``_nrt=False``, numba's target option for this, ``numba.core.options``); the numbers they
compute are the same bit for bit. A kernel that allocates (``flow_step``), calls Python in
``objmode`` (the FMM) or returns an array keeps plain ``njit(cache=True)``: a kernel
compiled without reference counting must never hand an array to a caller that counts, which
would release it once too often; ``tests/test_kernel_options.py`` checks that no such kernel
returns one.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from types import FunctionType
from typing import Any

from numba import njit
from numba.core.registry import CPUDispatcher

#: options of every kernel that neither allocates nor returns an array
KERNEL: dict[str, bool] = {"cache": True, "_nrt": False}

#: options of a kernel that takes the simulator's records and is called from other kernels
#: (:func:`kernel`): no CPython or C-callable wrapper
_CALLEE: dict[str, bool] = {"_nrt": False, "no_cpython_wrapper": True, "no_cfunc_wrapper": True}


class KernelDispatcher(CPUDispatcher):
    """A kernel compiled for calls from other kernels, without numba's CPython wrapper.

    The wrapper of a kernel whose arguments are the model, state and workspace records (some
    80 arrays) unboxes every one of them, and its compilation costs about 1 s per kernel,
    most of a cold compile of the small ones (``python experiments/cold_start/cold_start.py``).
    A call from Python goes to a twin compiled with the wrapper (and cached under its own name),
    built the first time Python calls; both are compiled from the same source and run the
    same code.
    """

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        twin = self.__dict__.get("_python_twin")
        if twin is None:
            f = self.py_func
            g = FunctionType(f.__code__, f.__globals__, f.__name__, f.__defaults__, f.__closure__)
            g.__qualname__ = f"{f.__qualname__}__from_python"  # its own cache files
            g.__module__ = f.__module__
            g.__doc__ = f.__doc__
            twin = njit(**KERNEL)(g)
            self.__dict__["_python_twin"] = twin
        return twin(*args, **kwargs)


#: ``BATHPRINT_KERNEL_WRAPPERS=1`` compiles every kernel with its wrapper, as before
#: :func:`kernel` (the baseline of ``experiments/cold_start/cold_start.py``)
WRAPPED = os.environ.get("BATHPRINT_KERNEL_WRAPPERS", "") == "1"


def kernel(py_func: Callable) -> CPUDispatcher:
    """Decorator of a kernel that takes the records and is called from other kernels:
    ``@njit(**KERNEL)`` without the CPython wrapper (:class:`KernelDispatcher`)."""
    if WRAPPED:
        return njit(**KERNEL)(py_func)
    dispatcher = KernelDispatcher(py_func=py_func, locals={}, targetoptions=dict(_CALLEE))
    dispatcher.enable_caching()
    return dispatcher
