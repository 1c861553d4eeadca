"""``python -m warpcontact.cli``: the command line (warpcontact.cli.main)."""

import sys

from warpcontact.cli import main

sys.exit(main())
