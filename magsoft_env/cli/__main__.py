"""``python -m magsoft_env.cli``."""

import sys

from . import main

sys.exit(main())
