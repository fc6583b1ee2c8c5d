"""The optional extras of pyproject.toml, and the check a command makes before it needs one.

``pip install shoal`` brings none of them, and every command's ``--help`` must work without
them, so their modules are imported only inside the code that uses them. A command that needs
one calls :func:`require` before it starts anything (a run's processes, a campaign's fields):
it raises :class:`~shoal.tools.errors.ExtraMissing`, which the ``shoal`` command prints as one
line naming the extra and how to install it. The CLI also turns a late ``ModuleNotFoundError``
of an extra's module into the same line (:func:`extra_of`).
"""

from __future__ import annotations

import importlib

from shoal.tools.errors import ExtraMissing

# extra -> the top-level modules it installs that shoal imports (pyproject.toml's
# [project.optional-dependencies]; dask comes with distributed).
EXTRAS: dict[str, tuple[str, ...]] = {
    "plot": ("matplotlib",),
    "cluster": ("distributed", "dask"),
    "ros2": ("rosbags",),
    "live": ("foxglove",),
    "physics": ("mujoco",),
}


def require(extra: str, needed_by: str) -> None:
    """ExtraMissing unless every module of ``extra`` imports; ``needed_by`` names what needs it
    (``shoal guard``, ``--live``) in the message."""
    for module in EXTRAS[extra]:
        try:
            importlib.import_module(module)
        except ImportError as exc:
            raise ExtraMissing(extra, needed_by, str(exc)) from None


def extra_of(exc: ImportError) -> str | None:
    """The extra whose module ``exc`` failed to import, or None (not an extra's module)."""
    top = (exc.name or "").partition(".")[0]
    return next((extra for extra, modules in EXTRAS.items() if top in modules), None)
