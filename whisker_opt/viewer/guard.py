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


def _x_display_answers(display: str, timeout_s: float) -> bool:
    """Whether an X server accepts a connection at ``display`` (``:N``, ``:N.S``, ``unix:N``, ``HOST:N``).

    A form this cannot read counts as answering (the display is then left to VTK).
    """
    import re
    import socket

    m = re.fullmatch(r"(?P<host>.*):(?P<num>[0-9]+)(\.[0-9]+)?", display.strip())
    if m is None:
        return True
    host, num = m.group("host"), int(m.group("num"))
    if host.startswith("/"):  # a socket path (XQuartz' launchd form)
        return os.path.exists(host)
    if host in ("", "unix"):
        path = f"/tmp/.X11-unix/X{num}"
        for address in ("\0" + path, path):  # the abstract socket (Linux) first, then the file
            with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
                sock.settimeout(timeout_s)
                try:
                    sock.connect(address)
                    return True
                except OSError:
                    continue
        if host == "unix":
            return False
        host = "localhost"  # ":N" falls back to TCP on the local machine, as Xlib does
    try:
        with socket.create_connection((host.strip("[]"), 6000 + num), timeout=timeout_s):
            return True
    except (OSError, ValueError):
        return False


def _wayland_answers(name: str, env: Mapping[str, str]) -> bool:
    """Whether the Wayland socket ``name`` (absolute, or under ``XDG_RUNTIME_DIR``) exists; True when unknown."""
    if os.path.isabs(name):
        return os.path.exists(name)
    runtime = env.get("XDG_RUNTIME_DIR")
    return True if not runtime else os.path.exists(os.path.join(runtime, name))


def display_problem(environ: Mapping[str, str] | None = None, platform: str | None = None,
                    probe: bool | None = None, timeout_s: float = 1.0) -> str | None:
    """Why no window can be opened, in a few words, or None when a display is available.

    On Linux and other X11/Wayland systems a display exists when ``DISPLAY`` or
    ``WAYLAND_DISPLAY`` is set and (with ``probe``) something answers there: an X server
    accepting a connection at ``DISPLAY`` (its socket, or TCP port 6000 + N), or the Wayland
    socket existing. macOS and Windows always have one.

    Parameters
    ----------
    environ : mapping, optional
        Environment (default ``os.environ``).
    platform : str, optional
        ``sys.platform`` value (default the running one).
    probe : bool, optional
        Check that the display answers (default: when ``environ`` is the real environment).
    timeout_s : float
        Time to wait for an X server's answer [s].

    Returns
    -------
    str or None
    """
    env = os.environ if environ is None else environ
    plat = sys.platform if platform is None else platform
    if plat.startswith(("win", "darwin", "cygwin")):
        return None
    display, wayland = env.get("DISPLAY"), env.get("WAYLAND_DISPLAY")
    if not (display or wayland):
        return "no display found (DISPLAY/WAYLAND_DISPLAY unset)"
    if not (environ is None if probe is None else probe):
        return None
    if display and _x_display_answers(display, timeout_s):
        return None
    if wayland and _wayland_answers(wayland, env):
        return None
    shown = [f"DISPLAY={display!r}" if display else "", f"WAYLAND_DISPLAY={wayland!r}" if wayland else ""]
    return f"no display answers at {' or '.join(w for w in shown if w)} (no X or Wayland server runs there)"


def is_headless(environ: Mapping[str, str] | None = None, platform: str | None = None,
                probe: bool | None = None) -> bool:
    """Whether no display is available to open a window on (:func:`display_problem`).

    Parameters
    ----------
    environ : mapping, optional
        Environment (default ``os.environ``).
    platform : str, optional
        ``sys.platform`` value (default the running one).
    probe : bool, optional
        Also check that the display answers (default: when ``environ`` is the real
        environment); a ``DISPLAY`` where no X server runs (``:99`` with nothing behind it) is
        then headless, and the viewer renders off-screen instead of drawing nothing.

    Returns
    -------
    bool
    """
    return display_problem(environ, platform, probe) is not None
