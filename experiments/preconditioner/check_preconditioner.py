"""The Newton part of ``preconditioner.py`` on the smallest stack: it
captures a solve by replaying the integrator's Python source (which breaks when a replayed
kernel changes), its GMRES reproduces the simulator's iteration count with the
simulator's preconditioner, and the whole axial problem as coarse space takes no more
iterations than the band alone."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

BENCH = Path(__file__).resolve().parents[1]  # experiments/
COLUMNS = {
    "nodes",
    "unknowns",
    "off_band_blocks",
    "solves",
    "preconditioner",
    "coarse_unknowns",
    "coarse_bandwidth",
    "simulator_iterations_rtol_0.05",
    "iterations_rtol_0.05",
    "iterations_rtol_0.001",
    "simulator_iterations_rtol_0.05_each",
    "iterations_rtol_0.05_each",
    "iterations_rtol_0.001_each",
    "unconverged_solves",
    "band_lu_ms",
    "coarse_lu_ms",
    "coarse_lu_over_band_lu",
}


def test_newton_part_reproduces_the_simulators_count(tmp_path, monkeypatch, load_script):
    monkeypatch.syspath_prepend(str(BENCH))  # the script imports _common and bench_contact
    mod = load_script(BENCH / "preconditioner" / "preconditioner.py")
    args = ["--part", "newton", "--sizes", "100", "--solves", "1", "--out", str(tmp_path)]
    assert mod.main(args) == 0
    with (tmp_path / "preconditioner_newton.csv").open() as f:
        reader = csv.DictReader(f)
        assert set(reader.fieldnames or ()) == COLUMNS
        rows = {r["preconditioner"]: r for r in reader}
    assert set(rows) == set(mod.NEWTON_PRECONDITIONERS)
    band, axial = rows["band"], rows["axial"]
    assert int(band["nodes"]) == 100 and int(band["solves"]) == 1
    assert int(band["off_band_blocks"].split(".")[0]) > 0  # the turns touch
    simulator = int(band["simulator_iterations_rtol_0.05_each"])
    assert simulator >= 1
    assert int(band["iterations_rtol_0.05_each"]) == simulator
    for r in rows.values():
        assert int(r["unconverged_solves"]) == 0
        assert float(r["iterations_rtol_0.001"]) >= float(r["iterations_rtol_0.05"]) >= 1
    for tol in ("0.05", "0.001"):
        assert float(axial[f"iterations_rtol_{tol}"]) <= float(band[f"iterations_rtol_{tol}"])
    assert int(axial["coarse_unknowns"]) == 100  # one z a node (none is clamped here)
    assert int(rows["hat_4_z"]["coarse_unknowns"]) == 26  # nodes 0, 4, ..., 100 of 0..99
    assert float(axial["coarse_lu_over_band_lu"]) > 0.0
    assert (tmp_path / "preconditioner_newton.meta.json").exists()


def test_backsub_part_times_two_orders_of_the_same_solve(tmp_path, monkeypatch, load_script):
    """The back-substitution by columns (GMRES's preconditioner) solves the same system as
    the row-oriented one to round-off, on both sides of the switch to the bounded loops."""
    monkeypatch.syspath_prepend(str(BENCH))
    mod = load_script(BENCH / "preconditioner" / "preconditioner.py")
    path = mod.backsub_part(tmp_path, sizes=(3, 40))
    with path.open() as f:
        rows = list(csv.DictReader(f))
    assert [int(r["unknowns"]) for r in rows] == [9, 120]
    for r in rows:
        assert float(r["max_rel_difference"]) < 1e-13
        assert float(r["rows_us"]) > 0.0 and float(r["columns_us"]) > 0.0


def test_diagonal_part_times_both_lus_of_the_same_system(tmp_path, monkeypatch, load_script):
    """GMRES's LU with diagonal pivots solves the same system as with partial pivoting, to
    round-off, small (bounded loops only) and larger."""
    monkeypatch.syspath_prepend(str(BENCH))
    mod = load_script(BENCH / "preconditioner" / "preconditioner.py")
    path = mod.diagonal_part(tmp_path, sizes=(3, 40), pile=False)
    with path.open() as f:
        rows = list(csv.DictReader(f))
    assert [int(r["unknowns"]) for r in rows] == [9, 120]
    for r in rows:
        assert float(r["max_rel_difference"]) < 1e-13
        assert r["diagonal_pivots_pass"] == "True"  # diagonally dominant: no swap is due
        for key in ("lu_partial_us", "lu_diagonal_us", "solve_partial_us", "solve_diagonal_us"):
            assert float(r[key]) > 0.0


def test_blocks_part_times_the_stacks_two_kernels_alone(tmp_path, monkeypatch, load_script):
    """``--part blocks``: a stack's pattern of off-band blocks (each node with the 4 nearest
    nodes a turn up, both ways, each node block written twice) and a row per size with the
    cost per block and per node, and of the product by merged rows."""
    monkeypatch.syspath_prepend(str(BENCH))
    mod = load_script(BENCH / "preconditioner" / "preconditioner.py")
    rng = np.random.default_rng(0)
    n = 200
    cpl = mod.stack_couplings(n, rng)
    k = int(cpl.count[0])
    distinct = 2 * sum(
        1 for i in range(n) for d in mod.TURN_OFFSETS if 0 <= i + mod.TURN_NODES + d < n
    )
    assert k == mod.WRITES * distinct
    rows, cols = cpl.row[:k], cpl.col[:k]
    assert set(zip(rows.tolist(), cols.tolist(), strict=True)) == set(
        zip(cols.tolist(), rows.tolist(), strict=True)
    )  # both ways
    assert np.all(np.abs(np.abs(rows - cols) - mod.TURN_NODES) <= 2)
    path = mod.blocks_part(tmp_path, sizes=(100, 200))
    with path.open() as f:
        out = list(csv.DictReader(f))
    assert [int(r["nodes"]) for r in out] == [100, 200]
    for r in out:
        assert float(r["ns_per_block"]) > 0.0 and float(r["ns_per_node_backsub"]) > 0.0
        assert float(r["blocks_mb"]) == pytest.approx(int(r["blocks"]) * 88 / 1e6)
        assert int(r["merged_blocks"]) * mod.WRITES == int(r["blocks"])
        assert float(r["product_merged_us"]) > 0.0 and float(r["merge_us"]) > 0.0


def test_forest_solve_is_exact_on_chains_of_turns(monkeypatch, load_script):
    """With couplings only a turn apart (m nodes) and none along the filament, the axial
    matrix is its own line forest: forest_solve returns its exact solution."""
    monkeypatch.syspath_prepend(str(BENCH))
    mod = load_script(BENCH / "preconditioner" / "preconditioner.py")
    rng = np.random.default_rng(1)
    n, m = 60, 7
    k = rng.uniform(1.0, 2.0, n - m)
    a = np.diag(rng.uniform(0.5, 1.0, n))
    for i in range(n - m):  # a symmetric positive-definite chain: k (e_i - e_j)(e_i - e_j)^T
        j = i + m
        a[i, i] += k[i]
        a[j, j] += k[i]
        a[i, j] = a[j, i] = -k[i]
    import scipy.sparse as sp

    forest = mod.line_forest(sp.csr_matrix(a), reach=2)
    assert np.array_equal(forest.parent[: n - m], np.arange(m, n))
    assert np.all(forest.parent[n - m :] == -1)
    r = rng.normal(size=n)
    np.testing.assert_allclose(mod.forest_solve(forest, r), np.linalg.solve(a, r), rtol=1e-12)


def test_forest_solve_is_exact_on_a_tree(monkeypatch, load_script):
    """An unsymmetric forest with nodes of two children: forest_solve against the dense
    matrix it stands for; a pivot that is not positive is an error, not a NaN."""
    monkeypatch.syspath_prepend(str(BENCH))
    mod = load_script(BENCH / "preconditioner" / "preconditioner.py")
    rng = np.random.default_rng(3)
    n = 12
    parent = np.array([3, 3, 5, 6, 6, 8, 9, 9, 11, -1, 11, -1])  # 0, 1 -> 3; 3, 4 -> 6; ...
    up, down = rng.uniform(-1.0, 1.0, n), rng.uniform(-1.0, 1.0, n)
    diagonal = rng.uniform(4.0, 5.0, n)
    f = mod.Forest(diagonal, parent, up, down)
    dense = np.diag(diagonal)
    for i, p in enumerate(parent):
        if p >= 0:
            dense[i, p], dense[p, i] = up[i], down[i]
    r = rng.normal(size=n)
    np.testing.assert_allclose(mod.forest_solve(f, r), np.linalg.solve(dense, r), rtol=1e-12)
    bad = mod.Forest(np.where(np.arange(n) == 6, -1.0, diagonal), parent, up, down)
    with pytest.raises(ValueError, match="forest pivot 6"):
        mod.forest_solve(bad, r)


def _system(rng: np.random.Generator, n: int):
    """A nonsymmetric diagonally dominant system and an inexact preconditioner for it."""
    a = rng.normal(size=(n, n)) + 2 * n**0.5 * np.eye(n)
    m = np.linalg.inv(np.diag(np.diag(a)))

    def apply(v):
        z = m @ v
        return z, a @ z

    return a, apply


def test_recycler_keeps_directions_and_their_images(monkeypatch, load_script):
    """Directions kept from a GMRES solve (fgmres orthogonalises what apply returns in place,
    so they are copied): each kept A w is A times its w, and they are orthonormal; the same
    right-hand side again starts at a residual within the tolerance."""
    monkeypatch.syspath_prepend(str(BENCH))
    mod = load_script(BENCH / "preconditioner" / "preconditioner.py")
    rng = np.random.default_rng(2)
    n = 40
    a, apply = _system(rng, n)
    b = rng.normal(size=n)
    kept = []

    def keeping(v):
        z, y = apply(v)
        kept.append((z, y))
        return z, y

    its, ok, x = mod.fgmres_solution(a, b, keeping, 1e-8)
    assert ok and its >= 2
    assert np.linalg.norm(b - a @ x) <= 1e-8 * np.linalg.norm(b)
    rec = mod.Recycler(keep=its)
    rec.add(kept)
    aw = np.array(rec.aw)
    np.testing.assert_allclose(aw @ aw.T, np.eye(len(rec.aw)), atol=1e-10)
    for w, y in zip(rec.w, rec.aw, strict=True):
        np.testing.assert_allclose(a @ w, y, atol=1e-10)
    x0, r = rec.start(b)
    np.testing.assert_allclose(r, b - a @ x0, atol=1e-10)
    assert np.linalg.norm(r) <= 1e-6 * np.linalg.norm(b)


def test_recycler_starts_anew_when_full(monkeypatch, load_script):
    """Kept solutions, at most ``keep``: one more starts it anew from that one (Fischer's
    restart); a right-hand side in the span of those kept is solved by the start alone,
    one outside it is not; a pair already in the span adds nothing."""
    monkeypatch.syspath_prepend(str(BENCH))
    mod = load_script(BENCH / "preconditioner" / "preconditioner.py")
    rng = np.random.default_rng(4)
    n = 30
    a, _apply = _system(rng, n)
    xs = rng.normal(size=(5, n))
    rec = mod.Recycler(keep=3)
    for k, x in enumerate(xs):
        rec.add([(x, a @ x)])
        assert len(rec.w) == (k + 1 if k < 3 else k - 2)
    b = a @ (xs[3] - 2 * xs[4])  # in the span of the two kept since the restart
    x0, r = rec.start(b)
    assert np.linalg.norm(r) < 1e-10 * np.linalg.norm(b)
    np.testing.assert_allclose(x0, xs[3] - 2 * xs[4], atol=1e-8)
    _x0, r_old = rec.start(a @ xs[0])  # dropped at the restart
    assert np.linalg.norm(r_old) > 1e-3 * np.linalg.norm(a @ xs[0])
    rec.add([(xs[3] + xs[4], a @ (xs[3] + xs[4]))])
    assert len(rec.w) == 2  # already in the span: dropped


def test_settled_part_compares_variants_on_consecutive_solves(tmp_path, monkeypatch, load_script):
    """``--part settled`` on the smallest settled stack: a row per variant, every solve
    converged (the kept variants checked on their true residual), the band's count the
    simulator's, the whole axial problem and the kept solutions no worse than the band."""
    monkeypatch.syspath_prepend(str(BENCH))
    mod = load_script(BENCH / "preconditioner" / "preconditioner.py")
    path = mod.settled_part([300], 8, tmp_path, pile=False)
    with path.open() as f:
        rows = {r["variant"]: r for r in csv.DictReader(f)}
    expected = {"band", "axial", "hat_4_z", "lines"}
    expected |= {f"recycled_{k}" for k in mod.RECYCLED} | {f"projected_{k}" for k in mod.PROJECTED}
    assert set(rows) == expected
    band = rows["band"]
    assert band["case"] == "pressed stack" and int(band["nodes"]) == 300
    assert int(band["solves"]) == 8 and int(band["matrices"]) >= 1
    assert float(band["iterations"]) == pytest.approx(float(band["simulator_iterations"]))
    for r in rows.values():
        assert int(r["unconverged_solves"]) == 0
    for v in ("axial", f"projected_{max(mod.PROJECTED)}", f"recycled_{max(mod.RECYCLED)}"):
        assert float(rows[v]["iterations"]) <= float(band["iterations"])
    assert float(rows[f"projected_{max(mod.PROJECTED)}"]["vector_passes_per_solve"]) > 0.0
    assert int(rows["lines"]["extra_products_per_iteration"]) == 1
