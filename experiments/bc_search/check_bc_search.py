"""Hand-run check of bc_search.py on a tiny budget (``python -m pytest
check_bc_search.py``; not part of the test suite)."""

from __future__ import annotations


def test_bc_search_smoke_writes_its_row_and_resumes(tmp_path, monkeypatch, load_script):
    """bc_search.py with a tiny budget: one row on the validation targets
    only, written to the CSV; run again, the row is kept, not recomputed."""
    from pathlib import Path

    import bathprint.envs.v1 as v1

    mod = load_script(Path(__file__).resolve().parent / "bc_search.py")
    seen: list[str] = []
    real = v1.BathprintEnvV1.fixed_set_target

    def spy(self, target_set, index):
        seen.append(target_set)
        return real(self, target_set, index)

    monkeypatch.setattr(v1.BathprintEnvV1, "fixed_set_target", spy)
    out = tmp_path / "bc.csv"
    args = ["--env", "bathprint/CoilRadius-v1", "--rows", "0", "--targets-scale", "0.0125",
            "--episodes", "2", "--out", str(out)]  # fmt: skip
    assert mod.main(args) == 0
    rows = out.read_text().splitlines()
    assert len(rows) == 2 and rows[0].startswith("targets,")
    first = dict(zip(rows[0].split(","), rows[1].split(","), strict=True))
    assert int(first["targets"]) == 2 and int(first["demonstration_pairs"]) > 0
    assert 0.0 < float(first["validation_mean_metric"]) < 10.0
    assert set(seen) == {"validation"}
    assert mod.main(args) == 0  # resumed: nothing left to do, the row kept as it was
    assert out.read_text().splitlines() == rows
    diag = tmp_path / "diag.csv"
    assert mod.main(["--env", "bathprint/CoilRadius-v1", "--diagnose", "0", "--targets-scale",
                     "0.0125", "--episodes", "1", "--out", str(diag)]) == 0  # fmt: skip
    lines = diag.read_text().splitlines()
    assert len(lines) == 2 + len(mod.NOISE_STDS)
    values = [float(line.rsplit(",", 1)[1]) for line in lines[1:]]
    assert 0.0 < values[0] < 2.0  # the action RMS, in action units (each in [-1, 1])
    assert values[1] < 1e-4  # the printing actions replayed without noise print the target
    assert values[-1] > values[1]
    ens = tmp_path / "ens.csv"
    assert mod.main(["--env", "bathprint/CoilRadius-v1", "--ensemble", "2", "--ensemble-row",
                     "0", "--targets-scale", "0.0125", "--episodes", "1", "--out",
                     str(ens)]) == 0  # fmt: skip
    lines = ens.read_text().splitlines()
    assert [line.split(",")[0] for line in lines[1:]] == ["actor 0", "actor 1", "mean of 2"]
    assert set(seen) == {"validation"}
    stack = tmp_path / "stack.csv"
    common = ["--env", "bathprint/CoilRadius-v1", "--ensemble-row", "0", "--targets-scale",
              "0.0125", "--episodes", "1", "--out", str(stack)]  # fmt: skip
    assert mod.main(["--frame-stack", "1,3", *common]) == 0
    lines = stack.read_text().splitlines()
    assert [line.split(",")[0] for line in lines[1:]] == ["1", "3"]
    pairs = [int(line.split(",")[3]) for line in lines[1:]]
    assert pairs[0] == pairs[1] > 0  # the same replays, seen through the stack
    assert mod.main(["--frame-stack", "3", *common]) == 0  # kept, not recomputed
    assert stack.read_text().splitlines() == lines
    assert set(seen) == {"validation"}
