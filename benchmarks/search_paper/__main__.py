"""``python -m benchmarks.search_paper``: see the package's docstring, or ``--help``."""

from .cli import main

raise SystemExit(main())
