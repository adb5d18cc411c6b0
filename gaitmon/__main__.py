"""``python -m gaitmon``: the command line."""

from gaitmon.cli import main

raise SystemExit(main())
