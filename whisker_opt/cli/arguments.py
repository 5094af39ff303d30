"""Checks of command-line values, made before any computation.

The ``argparse`` ``type=`` functions here turn a bad option value into
:class:`argparse.ArgumentTypeError`; argparse then prints one line naming the option, e.g.
``whisker-opt compensate: error: argument --step: 0 is outside the allowed range (0, 100] mm``,
and exits with status 2. Ranges are written as in ``docs/config.md``: ``(a, b]`` excludes a
and includes b (real numbers), ``a..b`` is an integer range including both ends.

:func:`ensure_writable_dir` checks that an output folder can be created and written
without creating anything; the runners call it before computing.
"""

from __future__ import annotations

import argparse
import math
import os
import tempfile
from pathlib import Path
from typing import Callable

#: Extensions :meth:`pyvista.Plotter.screenshot` writes (raster images).
IMAGE_EXTENSIONS = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")
#: Longest file name most file systems accept [bytes].
_NAME_MAX = 255


class OutputError(ValueError):
    """An output path that cannot be created or written (a user error: the message names it)."""


class ArgumentError(ValueError):
    """An option value that the run file makes impossible, e.g. ``--delta-ref`` beyond
    ``scene.deflection`` (a user error: the message names the option, the value and the range)."""


def _fmt(x: float) -> str:
    return f"{x:g}"


def _describe_range(lo: float | None, hi: float | None, lo_open: bool, hi_open: bool, unit: str) -> str:
    left = "(-inf" if lo is None else ("(" if lo_open else "[") + _fmt(lo)
    right = "inf)" if hi is None else _fmt(hi) + (")" if hi_open else "]")
    return f"{left}, {right}" + (f" {unit}" if unit else "")


def parse_finite(text: str) -> float:
    """A finite float from a command-line string.

    Parameters
    ----------
    text : str

    Returns
    -------
    float

    Raises
    ------
    argparse.ArgumentTypeError
        ``text`` is not a number, or is NaN or infinite (also ``1e309``, which overflows).
    """
    try:
        x = float(text)
    except (TypeError, ValueError):
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(x):
        raise argparse.ArgumentTypeError(f"{text} is not a finite number")
    return x


def finite_float_in(lo: float | None, hi: float | None, unit: str = "", lo_open: bool = False,
                    hi_open: bool = False) -> Callable[[str], float]:
    """An argparse type: a finite float in a range.

    Parameters
    ----------
    lo, hi : float or None
        Bounds; None = unbounded on that side.
    unit : str
        Unit named in the message (e.g. ``"mm"``).
    lo_open, hi_open : bool
        Exclude the bound.

    Returns
    -------
    callable
        ``str -> float``, raising :class:`argparse.ArgumentTypeError` with the value and
        the allowed range.
    """
    rng = _describe_range(lo, hi, lo_open, hi_open, unit)

    def check(text: str) -> float:
        x = parse_finite(text)
        below = lo is not None and (x <= lo if lo_open else x < lo)
        above = hi is not None and (x >= hi if hi_open else x > hi)
        if below or above:
            raise argparse.ArgumentTypeError(f"{text} is outside the allowed range {rng}")
        return x

    check.__name__ = f"number in {rng}"
    return check


def positive_float(hi: float | None = None, unit: str = "") -> Callable[[str], float]:
    """An argparse type: a finite float > 0 (and <= ``hi`` when given); see :func:`finite_float_in`."""
    return finite_float_in(0.0, hi, unit, lo_open=True)


def int_in(lo: int, hi: int, unit: str = "", name: str = "") -> Callable[[str], int]:
    """An argparse type: an integer in ``lo..hi`` (both included).

    Parameters
    ----------
    lo, hi : int
    unit : str
        Unit named in the message (e.g. ``"pixels"``).
    name : str
        Written before the value in the message (``top=0 is outside ...``), as the
        function that checks the value again words it.

    Returns
    -------
    callable
        ``str -> int``, raising :class:`argparse.ArgumentTypeError` with the value and the range.
    """
    rng = f"{lo}..{hi}" + (f" {unit}" if unit else "")

    def check(text: str) -> int:
        try:
            n = int(str(text).strip())
        except (TypeError, ValueError):
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer (allowed range {rng})") from None
        if not lo <= n <= hi:
            value = f"{name}={n}" if name else str(text)
            raise argparse.ArgumentTypeError(f"{value} is outside the allowed range {rng}")
        return n

    check.__name__ = f"integer in {rng}"
    return check


#: ``--window-size W H``: each of the two numbers, in pixels.
window_size = int_in(50, 10_000, "pixels")


def eval_id(text: str) -> str:
    """An argparse type: an evaluation id of ``evaluations.csv`` (an integer >= 0).

    Parameters
    ----------
    text : str

    Returns
    -------
    str
        The id as ``evaluations.csv`` writes it (no sign, no leading zeros).

    Raises
    ------
    argparse.ArgumentTypeError
        Not an integer in 0..10^12.
    """
    return str(int_in(0, 10**12)(text))


def setting(text: str) -> str:
    """An argparse type: a ``KEY=VALUE`` setting of ``--set`` (a dotted key, a YAML value).

    Whether the key and the value suit the run file is checked when the file is read
    (:func:`whisker_opt.config.model.load_config`), with the file's own messages.

    Parameters
    ----------
    text : str

    Returns
    -------
    str
        ``text`` unchanged.

    Raises
    ------
    argparse.ArgumentTypeError
        No ``=``, or an empty key or an empty part of the dotted key.
    """
    key, sep, _ = str(text).partition("=")
    if not sep or not all(k.strip() for k in key.split(".")):
        raise argparse.ArgumentTypeError(f"{text!r} is not KEY=VALUE with a dotted key, "
                                          "e.g. optimiser.ga.population=20")
    return str(text)


def preset_setting(choices: tuple[str, ...]) -> Callable[[str], str]:
    """An argparse type: ``--preset NAME`` as the setting ``fidelity.preset=NAME``.

    ``--preset`` appends to the same list as ``--set``, so the two apply in the order given.

    Parameters
    ----------
    choices : tuple of str
        The fidelity presets.

    Returns
    -------
    callable
        ``str -> str``, raising :class:`argparse.ArgumentTypeError` for a name not in ``choices``.
    """
    def check(text: str) -> str:
        if text not in choices:
            raise argparse.ArgumentTypeError(f"invalid choice: {text!r} (choose from {', '.join(choices)})")
        return f"fidelity.preset={text}"

    check.__name__ = "preset"
    return check


def settings_arguments(p: argparse.ArgumentParser, example: str, defaults_help: str, after: str = "") -> None:
    """The options that change a run file on the command line: ``--set``, ``--preset``, ``--defaults``.

    ``--set KEY=VALUE`` and ``--preset NAME`` append to one list, ``args.settings``, in the order given
    (read by :func:`whisker_opt.config.model.load_config`); ``--defaults`` is ``args.defaults``.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The command's parser.
    example : str
        A ``KEY=VALUE`` example for the command's ``--set`` help.
    defaults_help : str
        What ``--defaults`` means for the command.
    after : str
        Help text added after the ``--set`` example, e.g. where the result is stored.
    """
    from whisker_opt.experiment.fidelity import PRESET_NAMES

    p.add_argument("--set", dest="settings", action="append", type=setting, default=[], metavar="KEY=VALUE",
                   help=f"set a run-file key over the file, e.g. --set {example} (repeatable; "
                        f"the value is read as YAML{after})")
    p.add_argument("--preset", dest="settings", action="append", type=preset_setting(PRESET_NAMES),
                   metavar="{" + ",".join(PRESET_NAMES) + "}", help="fidelity preset: --set fidelity.preset=NAME")
    p.add_argument("--defaults", action="store_true", help=defaults_help)


def image_path(text: str) -> Path:
    """An argparse type: the path of an image file to write (``--screenshot``).

    Parameters
    ----------
    text : str

    Returns
    -------
    Path

    Raises
    ------
    argparse.ArgumentTypeError
        Empty, an existing folder, or an extension the screenshot cannot be written in
        (:data:`IMAGE_EXTENSIONS`; pyvista reads the extension case-sensitively).
    """
    if not str(text).strip():
        raise argparse.ArgumentTypeError("an empty path; give an image file such as view.png")
    p = Path(text)
    if len(os.fsencode(p.name)) > _NAME_MAX:
        raise argparse.ArgumentTypeError(f"{text}: the file name is longer than {_NAME_MAX} bytes")
    try:
        is_dir = p.is_dir()
    except OSError as exc:
        raise argparse.ArgumentTypeError(f"{text}: {exc.strerror or exc}") from None
    if is_dir:
        raise argparse.ArgumentTypeError(f"{text} is a folder; give an image file such as {p / 'view.png'}")
    ext = p.suffix
    if ext not in IMAGE_EXTENSIONS or p.stem in ("", "."):
        what = f"has the extension {ext!r}" if ext else "has no extension"
        case = " (lower case)" if ext.lower() in IMAGE_EXTENSIONS else ""
        raise argparse.ArgumentTypeError(f"{text} {what}; allowed{case}: {', '.join(IMAGE_EXTENSIONS)}")
    return p


def nonempty_path(text: str) -> Path:
    """An argparse type: a non-empty path (``--out``, a run directory).

    Whether it can be written is checked by :func:`ensure_writable_dir` once the command
    knows it will write there.

    Parameters
    ----------
    text : str

    Returns
    -------
    Path

    Raises
    ------
    argparse.ArgumentTypeError
        ``text`` is empty or blank.
    """
    if not str(text).strip():
        raise argparse.ArgumentTypeError("an empty path; give a folder")
    return Path(text)


def _exists(p: Path, what: str, path: str | Path) -> bool:
    try:
        return p.exists()
    except OSError as exc:  # a name too long, a parent that cannot be searched
        raise OutputError(f"{what} {path}: {exc.strerror or exc}") from None


def ensure_writable_dir(path: str | Path, what: str) -> Path:
    """Check that ``path`` is a writable folder or can be created as one; create nothing.

    The nearest existing ancestor of ``path`` (``path`` itself when it exists) must be a
    folder in which a file can be created: a temporary file is created there and removed
    at once, which also detects read-only file systems and permissions a root user does
    not bypass.

    Parameters
    ----------
    path : path-like
        The output folder a command is about to create or write into.
    what : str
        How the message names it: the option (``--out``) or the config key
        (``run.yaml: output.results_dir``).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    OutputError
        Empty path; ``path`` or an ancestor is a file; the folder cannot be written.
    """
    if not str(path).strip():
        raise OutputError(f"{what}: an empty path; give a folder")
    p = Path(path)
    probe = p
    while not _exists(probe, what, path):
        if probe.is_symlink():
            raise OutputError(f"{what} {path}: {probe} is a symbolic link that leads nowhere (broken, or a loop)")
        if probe.parent == probe:
            break
        probe = probe.parent
    if not probe.is_dir():
        if probe == p:
            kind = "a file, not a folder" if probe.is_file() else "not a folder"
            raise OutputError(f"{what} {path}: exists and is {kind}")
        raise OutputError(f"{what} {path}: cannot create a folder there, {probe} is a file")
    try:
        fd, tmp = tempfile.mkstemp(prefix=".whisker-opt-write-test.", suffix=".tmp", dir=probe)
    except OSError as exc:
        where = "" if probe == p else f" (the folder would be created in {probe})"
        raise OutputError(f"{what} {path}: {probe} is not writable: {exc.strerror or exc}{where}") from None
    os.close(fd)
    try:
        os.unlink(tmp)
    except OSError:
        pass
    return p


#: The checking argparse types of ``whisker-opt view`` (:func:`whisker_opt.viewer.command.add_view_args`).
VIEW_TYPES: dict[str, Callable[[str], object]] = {
    "screenshot": image_path,
    "clim_percentile": finite_float_in(0.0, 50.0, "%", hi_open=True),
    "delta": finite_float_in(0.0, 30.0, "mm"),
    "rank": int_in(1, 1_000_000),
    "eval_id": eval_id,
    "scale": finite_float_in(0.0, 1000.0),
    "window_size": window_size,
}
