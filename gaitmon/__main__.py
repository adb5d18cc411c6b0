"""``python -m gaitmon``: the command line."""

import sys

try:
    from gaitmon.cli import main
except KeyboardInterrupt:  # Ctrl-C while starting up: nothing has happened yet
    print("gaitmon: interrupted", file=sys.stderr)
    raise SystemExit(130) from None

raise SystemExit(main())
