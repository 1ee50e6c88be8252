"""``python -m robolobes``: the command line."""

import sys

from robolobes.main import main

sys.exit(main())
