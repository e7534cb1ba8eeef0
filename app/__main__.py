"""``python -m app``: the service under uvicorn (:mod:`app.cli`).

SIGTERM and SIGINT are held from the first statement on (:func:`app.cli.hold_signals`), so that
a signal that comes while the process imports and starts is a request to stop gracefully, not a
kill: uvicorn gets it as soon as its own handlers are in place.
"""

from .cli import hold_signals

hold_signals()

import sys  # noqa: E402 - after the signals are held

from .cli import main  # noqa: E402

sys.exit(main())
