"""``python -m pfpeople.cli``: the ``pfpeople`` command."""

from pfpeople.cli import main

raise SystemExit(main())
