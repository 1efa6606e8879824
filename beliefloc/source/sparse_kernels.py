"""SciPy's kernels behind ``sparse @ vector``, called with an output vector of our own.

``scipy.sparse._sparsetools`` is private: a SciPy that moves it leaves both names None, and their
callers fall back to the public product (or ``np.add.reduceat``), with the same results. This module
is the one place that reaches into it. Each kernel *adds* ``A @ x`` onto its output, so the output
is zeroed first; a CSR matrix's own arrays given to ``csc_matvec`` multiply by its transpose.
"""

from __future__ import annotations

from collections.abc import Callable

csr_matvec: Callable[..., None] | None
csc_matvec: Callable[..., None] | None
try:
    from scipy.sparse._sparsetools import csc_matvec, csr_matvec
except ImportError:  # pragma: no cover - a SciPy that moved them
    csr_matvec = csc_matvec = None
