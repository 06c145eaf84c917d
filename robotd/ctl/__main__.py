"""``python -m robotd.ctl``: robotctl without its console script."""

import sys

from robotd.ctl import main

sys.exit(main())
