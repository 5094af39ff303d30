"""What the viewer needs of its environment, and its errors.

pyvista is an optional extra: only :func:`require_pyvista` imports it, so every module of
the viewer imports without it and the ``view`` command can register (and print its
``--help``) on an installation without the ``viewer`` extra.
"""

from __future__ import annotations

import os
import sys
from typing import Mapping

INSTALL_HINT = "install the viewer extra: pip install 'whisker-opt[viewer]'"


class ViewerError(ValueError):
    """A request the viewer cannot serve; the message names the path, field or value."""


class ViewerUnavailable(ImportError):
    """pyvista (the optional ``viewer`` extra) is not installed."""


def require_pyvista():
    """Import pyvista or raise :class:`ViewerUnavailable` with the install command.

    Returns
    -------
    module
        The ``pyvista`` module.

    Raises
    ------
    ViewerUnavailable
        pyvista cannot be imported (also when ``sys.modules["pyvista"]`` is None).
    """
    try:
        import pyvista
    except ImportError as exc:  # includes sys.modules["pyvista"] = None
        raise ViewerUnavailable(
            f"the result viewer needs pyvista, which is not importable ({exc}); {INSTALL_HINT}"
        ) from exc
    return pyvista


def is_headless(environ: Mapping[str, str] | None = None, platform: str | None = None) -> bool:
    """Whether no display is available to open a window on.

    On Linux and other X11/Wayland systems a display exists when ``DISPLAY`` or
    ``WAYLAND_DISPLAY`` is set; macOS and Windows always have one.

    Parameters
    ----------
    environ : mapping, optional
        Environment (default ``os.environ``).
    platform : str, optional
        ``sys.platform`` value (default the running one).

    Returns
    -------
    bool
    """
    env = os.environ if environ is None else environ
    plat = sys.platform if platform is None else platform
    if plat.startswith(("win", "darwin", "cygwin")):
        return False
    return not (env.get("DISPLAY") or env.get("WAYLAND_DISPLAY"))
