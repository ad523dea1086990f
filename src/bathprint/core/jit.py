"""The numba options of the simulator's kernels (``@njit(**KERNEL)``).

The kernels take records of many arrays (:mod:`bathprint.core.records`) and call one
another many times per step: the stages, every force evaluation and each of its effects,
the solves. With numba's reference counting (NRT) on, every such call increments and
decrements the count of every array its arguments hold, about 7 ns per array
(``python benchmarks/bench_call_overhead.py``): an effect's call with its output record of
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

#: options of every kernel that neither allocates nor returns an array
KERNEL: dict[str, bool] = {"cache": True, "_nrt": False}
