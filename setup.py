"""The one compiled part: ``beliefloc.planning._fused`` (see its source). Everything else is in
pyproject.toml. The extension is optional: without a C compiler the install goes on and the search
takes its NumPy passes (the same plans, slower on beliefs of 10^6 states and more)."""

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
        )
    ]
)
