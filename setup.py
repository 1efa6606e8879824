"""The three compiled parts: ``beliefloc.planning._fused``, ``beliefloc.planning._lao`` and
``beliefloc.continuous._raycast`` (see their sources). Everything else is in pyproject.toml. All are
optional: without a C compiler the install goes on, the search takes its NumPy passes, LAO* its Python
bookkeeping and ray casting its NumPy traversal (the same plans and ranges, slower on beliefs of 10^6
states and more, on policies of thousands of expansions, and on the pose lattices of large floors)."""

import platform
import sys

from setuptools import Extension, setup

compile_args = ["-O3", "-ffp-contract=off"]  # no fused multiply-adds: predictions bit for bit as SciPy's
macros = []
libraries = ["m"]
if sys.platform.startswith("linux") and platform.machine() in ("x86_64", "AMD64"):
    macros.append(("BELIEFLOC_LIBMVEC", "1"))  # glibc's vector logarithm, used when the CPU has AVX2
    libraries.insert(0, "mvec")

setup(
    ext_modules=[
        Extension(
            "beliefloc.planning._fused",
            sources=["beliefloc/planning/_fused.c"],
            extra_compile_args=compile_args,
            define_macros=macros,
            libraries=libraries,
            optional=True,
        ),
        Extension(
            "beliefloc.planning._lao",
            sources=["beliefloc/planning/_lao.c"],
            extra_compile_args=compile_args,
            optional=True,
        ),
        Extension(
            "beliefloc.continuous._raycast",
            sources=["beliefloc/continuous/_raycast.c"],
            extra_compile_args=compile_args,
            libraries=["m"],
            optional=True,
        ),
    ]
)
