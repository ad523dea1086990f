"""``bathprint composites [--out DIR] [--quick]``: the Fig. 3 curves."""

from __future__ import annotations

import argparse
from typing import Any

from bathprint.cli._common import guarded


def add_parser(sub: Any) -> argparse.ArgumentParser:
    co = sub.add_parser(
        "composites",
        help="Fig. 3 curves: composite stiffness, density, settling in the gradient column",
    )
    co.add_argument("--out", default="runs/fig3")
    co.add_argument("--quick", action="store_true")
    co.set_defaults(run=run)
    return co


@guarded("bathprint composites")
def run(args: argparse.Namespace) -> int:
    from bathprint.paths import check_output_dir
    from bathprint.studies.reproduce import fig3

    res = fig3.run(check_output_dir(args.out, "--out"), quick=args.quick)
    print(f"{'flow ratio':>10} {'phi':>6} {'E_c/E_alg':>10} {'rho_c (kg/m^3)':>15}")
    for r in res["composites"]:
        print(
            f"{r['flow_ratio']:>10.3f} {r['inner_volume_fraction']:>6.3f} "
            f"{r['E_c_over_E_alg']:>10.4f} {r['density_kg_m3']:>15.1f}"
        )
    print("settling in the gradient column (height in mm, surface at 0):")
    for r in res["settling"]:
        print(
            f"  filament {r['filament']} ({r['density_kg_m3']:.0f} kg/m^3): simulated "
            f"{1e3 * r['settled_height_m']:8.3f}, expected {1e3 * r['expected_height_m']:8.3f}"
        )
    print(f"wrote {args.out}/fig3df_composites.png/.csv, fig3e_settling.png/.csv")
    return 0
