"""Physical effects. Each is a module with one numba kernel of the same shape:

    accumulate(pos, vel, acc, n_nodes, seg_rest, seg_mat, params, t,
               cx, cv, ca, force, band, work, do_jac) -> float

It adds its force to ``force`` and, when ``do_jac``, adds
``-(cx dF/dx + cv dF/dv + ca dF/da)`` into the banded Jacobian ``band``; it returns
its energy (or power, for drag). :func:`bathprint.core.assemble.assemble` calls only the
effects a scene lists, and counts each call, so an unlisted effect costs nothing.
"""

from bathprint.core.layout import EFFECT_NAMES

__all__ = ["EFFECT_NAMES"]
