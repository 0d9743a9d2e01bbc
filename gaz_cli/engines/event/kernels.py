"""The engine's kernels under the names of the one-file engine (before issue 17).

The kernels now live by concept (docs/architecture.md): :mod:`.layout`,
:mod:`.dynamics`, :mod:`.interactions`, :mod:`.boundaries`, :mod:`.neighbours`,
:mod:`.calendar`, :mod:`.prefetch`, :mod:`.loop`. This module only re-exports them,
for the tests and benchmarks written against ``kernels as K``; new code imports from
the module that owns a name.
"""

from gaz_cli.engines.event.calendar import _build_queue, _heap_push, _heap_remove, _next_bucket  # noqa: F401
from gaz_cli.engines.event.calendar import _q_insert, _q_remove  # noqa: F401
from gaz_cli.engines.event.dynamics import _state_at  # noqa: F401
from gaz_cli.engines.event.interactions import _pair_dt  # noqa: F401
from gaz_cli.engines.event.layout import *  # noqa: F401,F403
from gaz_cli.engines.event.loop import build  # noqa: F401
from gaz_cli.engines.event.neighbours.cells import _assign_cells  # noqa: F401
from gaz_cli.engines.event.neighbours.lists import _build_nl  # noqa: F401
