"""``python -m netcosim ARGS``: the ``netcosim`` command (:mod:`netcosim.cli`)."""

from .cli import main

raise SystemExit(main())
