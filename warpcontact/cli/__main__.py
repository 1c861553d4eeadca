"""``python -m warpcontact.cli``: the command line (warpcontact.cli.run)."""

from warpcontact.cli import run

run()
