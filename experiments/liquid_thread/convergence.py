"""How does the liquid thread's error against Trouton's hanging thread converge?

Prints the table of docs/physics/index.md#liquid: length and largest element-stretch error
at 1/4, 1/2, 3/4 and 9/10 of the blow-up time, for fixed steps and node spacings
(:func:`bathprint.analysis.validation.viscous_thread_under_gravity`).

    python experiments/liquid_thread/convergence.py
"""

from __future__ import annotations

import warnings

import numpy as np

from bathprint.analysis import validation as V

CASES = (
    (0.5, 0.2),
    (0.5, 0.1),
    (0.5, 0.05),
    (0.5, 0.025),
    (1.0, 0.0125),
    (0.5, 0.0125),
    (0.25, 0.0125),
)
FRACTIONS = (0.25, 0.5, 0.75, 0.9)


def main() -> None:
    print(
        "| node spacing | fixed step | length error at t/t* = "
        + ", ".join(map(str, FRACTIONS))
        + " | largest element stretch error |"
    )
    print("|---|---|---|---|")
    for spacing, step in CASES:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = V.viscous_thread_under_gravity(FRACTIONS, spacing_mm=spacing, time_step_s=step)
        length = [g / e - 1.0 for g, e in zip(r.length_m, r.exact_length_m, strict=True)]
        stretch = [
            float(np.max(np.abs(s / e - 1.0)))
            for s, e in zip(r.stretch, r.exact_stretch, strict=True)
        ]
        print(
            f"| {spacing:g} mm | {step:g} s | "
            + ", ".join(f"{x:.2e}" for x in length)
            + " | "
            + ", ".join(f"{x:.2e}" for x in stretch)
            + " |"
        )


if __name__ == "__main__":
    main()
