"""``python3 -m robotd.install``: what scripts/install-robot runs."""

from __future__ import annotations

import sys

from robotd.install.cli import main

sys.exit(main())
