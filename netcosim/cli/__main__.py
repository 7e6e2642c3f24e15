"""``python -m netcosim.cli ARGS``: the ``netcosim`` command."""

import sys

from . import main

sys.exit(main())
