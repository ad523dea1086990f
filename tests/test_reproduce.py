"""End-to-end `bathprint reproduce all --quick`: outputs exist and hold sane numbers."""

from __future__ import annotations

import json
import math

from bathprint.analysis.theory import beta_critical
from bathprint.cli import main


def test_reproduce_quick_writes_every_figure_with_sane_numbers(tmp_path) -> None:
    assert main(["reproduce", "all", "--quick", "--out", str(tmp_path), "--workers", "2"]) == 0
    for name in ("stability", "fig3df_composites", "fig3e_settling", "coils", "fig2", "fig1c"):
        assert (tmp_path / f"{name}.png").stat().st_size > 10_000, name
        assert (tmp_path / f"{name}.csv").stat().st_size > 50, name
    report = json.loads((tmp_path / "reproduce.json").read_text())
    beta_c = beta_critical()
    for onset in report["stability"]["result"]["simulated_onsets"].values():
        assert abs(onset / beta_c - 1) < 0.05
    for row in report["fig3"]["result"]["settling"]:
        assert abs(row["difference_m"]) < row["node_spacing_m"]
    slopes = report["fig2"]["result"]
    for key in ("l_over_R", "R_prefactor", "omega_prefactor"):
        value = slopes[key]
        assert value is None or math.isnan(value) or 0.01 < value < 100, (key, value)
    fig1c = report["fig1c"]["result"]
    assert fig1c["points"] == 2
    assert sum(fig1c["regimes"].values()) <= fig1c["points"]


def test_theory_json_has_the_onset_constants(capsys) -> None:
    assert main(["theory", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert round(data["beta_c"], 3) == 3.477
    assert abs(data["beta_c_spectral"] - data["beta_c"]) < 1e-6
    assert math.isclose(data["critical_length_prefactor"], data["beta_c"] ** (1 / 3))
    assert math.isclose(data["onset_frequency_prefactor"], data["beta_c"] ** (-1 / 3))
