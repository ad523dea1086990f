"""Physical effects. Each is a module with one numba kernel of the same shape:

    accumulate(model, rod, stage, out) -> float

(:mod:`bathprint.core.records`). It adds its force to ``out.force`` and, when
``stage.jac``, adds ``-(cx dF/dx + cv dF/dv + ca dF/da)`` into the Jacobian
(``out.band``); it returns its energy (or power, for drag). Material effects (gelation,
inclusions) instead update the material records once per step. :func:`bathprint.core.
assemble.assemble` calls only the effects a scene lists, and counts each call, so an
unlisted effect costs nothing.
"""

from bathprint.core.layout import EFFECT_NAMES

__all__ = ["EFFECT_NAMES"]
