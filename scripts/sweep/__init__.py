"""``topomap sweep``: servo episodes over seeds and settings, on a process pool or Ray.

Servo episodes over seeds and settings (``command``), run by a local process pool or a Ray
cluster (``backends``, ``ray_backend``), one episode per task (``episode``).
"""

from common.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "add_backend_arguments": "scripts.sweep.backends",
        "open_backend": "scripts.sweep.backends",
        "add_parser": "scripts.sweep.command",
        "run_sweep": "scripts.sweep.command",
        "configure_worker": "scripts.sweep.episode",
    },
)
