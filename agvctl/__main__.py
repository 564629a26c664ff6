"""``python -m agvctl``."""

import sys

from agvctl.cli import main

sys.exit(main())
