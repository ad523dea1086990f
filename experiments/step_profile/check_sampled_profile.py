"""The sampled profile (``sampled_profile.py``): its reading of perf's
report and of numba's symbols (running it needs Linux perf and a compile of every kernel,
so the measurement itself is a benchmark, not a test)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1]  # experiments/

LU = "_ZN9bathprint4core6banded7band_luB4v241B36c8tJTIeFIjxB2IKSgI4CrvQCltYEAA_3d_3dE5ArrayIdLi2E"
CONTACT = "_ZN9bathprint4core7effects7contact10accumulateB4v126B40c8tJTIeFIjxE4277Model"
REPORT = f"""# Samples: 2K of event 'cpu-clock:pppH'
#
# Overhead       Samples  Symbol
# ........  ............  ......
#
    40.00%           400  [.] {LU}
    30.00%           300  [.] {CONTACT}
    10.00%           100  [.] _ZN5numba7cpython7unicode6lengthB2v1E
    12.00%           120  [.] _PyEval_EvalFrameDefault
     8.00%            80  [k] clear_page_erms
"""


@pytest.fixture
def bench(load_script, monkeypatch):
    monkeypatch.syspath_prepend(str(BENCH))  # the script imports _common
    return load_script(BENCH / "step_profile" / "sampled_profile.py")


def test_kernel_names_come_from_the_mangled_symbols(bench) -> None:
    assert bench.kernel_name(LU) == "core.banded.band_lu"
    assert bench.kernel_name(CONTACT) == "core.effects.contact.accumulate"
    assert bench.kernel_name("_ZN5numba7cpython7unicode6lengthB2v1E") is None  # not ours
    assert bench.kernel_name("_PyEval_EvalFrameDefault") is None


def test_the_report_is_read_into_samples_per_kernel_and_shares(bench) -> None:
    counts = bench.parse_report(REPORT)
    assert counts == {
        "core.banded.band_lu": 400,
        "core.effects.contact.accumulate": 300,
        bench.REST: 300,  # numba's own helpers, the interpreter and the OS kernel
    }
    rows = bench.rows_of("pile, contact", counts)
    assert [r["function"] for r in rows] == [
        "core.banded.band_lu",
        "core.effects.contact.accumulate",
        bench.REST,
    ]
    assert sum(r["pct_of_window"] for r in rows) == pytest.approx(100.0)
    assert rows[0]["pct_of_window"] == pytest.approx(40.0)


def test_the_symbol_map_covers_the_compiled_kernels(bench, tmp_path, monkeypatch) -> None:
    """Functions numba compiled in this process (not loaded from a cache) are mapped with
    their addresses, each up to the next, in perf's map format."""
    from numba import njit

    @njit(cache=False)
    def twice(x: float) -> float:
        return 2.0 * x

    assert twice(2.0) == pytest.approx(4.0)
    pid = 10**9 + os.getpid()  # a file name no process of perf's will ask for
    n = bench.write_symbol_map(pid)
    path = Path(f"/tmp/perf-{pid}.map")
    try:
        lines = path.read_text().splitlines()
    finally:
        path.unlink()
    assert n == len(lines) >= 1
    starts = [int(line.split()[0], 16) for line in lines]
    assert starts == sorted(starts) and all(int(line.split()[1], 16) > 0 for line in lines)
    assert any("twice" in line for line in lines)


def test_a_stack_case_is_bench_contacts_relaxed_pressed_stack(bench, monkeypatch) -> None:
    """``--cases "pressed stack, N nodes"``: the settled part's stack of N nodes, relaxed for
    its warm-up at its largest step (here a short one, 100 nodes)."""
    monkeypatch.syspath_prepend(str(BENCH))  # the case comes from bench_contact
    from _common import experiment

    bench_contact = experiment("contact_cost")

    monkeypatch.setattr(bench_contact, "SETTLED_WARM_UP_S", 1e-3)
    assert bench.STACK_CASES == tuple(f"pressed stack, {n} nodes" for n in bench.STACK_SIZES)
    sim = bench.stack_state("pressed stack, 100 nodes")
    assert sim.n_nodes == 100 and sim.t == pytest.approx(1e-3)
    assert "contact" in sim.scene.effects
    assert sim.model.params[0]["max_step"] == pytest.approx(bench_contact.SETTLED_MAX_STEP_S)


def test_the_symbol_map_passes_over_dead_weak_proxies(bench) -> None:
    """gc lists weak proxies too, and isinstance of one whose object has died raises
    ReferenceError: the map is written all the same."""
    import gc
    import weakref

    class Gone:
        pass

    from numba import njit

    @njit(cache=False)
    def thrice(x: float) -> float:
        return 3.0 * x

    assert thrice(1.0) == pytest.approx(3.0)
    obj = Gone()
    proxy = weakref.proxy(obj)
    del obj
    gc.collect()
    assert any(o is proxy for o in gc.get_objects())
    with pytest.raises(ReferenceError):
        isinstance(proxy, int)
    pid = 10**9 + os.getpid() + 1
    try:
        assert bench.write_symbol_map(pid) >= 1
        assert "thrice" in Path(f"/tmp/perf-{pid}.map").read_text()
    finally:
        Path(f"/tmp/perf-{pid}.map").unlink(missing_ok=True)
