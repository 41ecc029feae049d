"""The package's figure style: one look for every figure ``--plots`` writes (docs/figures.md).

Every rig's ``figures`` module builds :class:`matplotlib.figure.Figure` objects directly (never
pyplot) inside :func:`style` (or a function decorated with :func:`styled`), and saves them with
:func:`save_figure` (through :func:`impactid.reports.save_figure_atomic`):

* labels in words with their unit in brackets, symbols in matplotlib's mathtext
  (:func:`axis_label`: ``"indentation $\\delta$ [µm]"``); a dimensionless quantity has ``[-]``;
* the Okabe–Ito colours (:data:`OKABE_ITO`), safe for the common colour-vision deficiencies, as the
  colour cycle; measured data in :data:`MEASURED`, simulations in :data:`SIMULATED`;
* a light grid, constrained layout, legends named in the papers' words;
* PNG at :data:`PNG_DPI` (200) dots per inch, or SVG or PDF (vector): the format is the ``fmt``
  argument of :func:`save_figure`, else the one :func:`figure_format` set for the block (the
  commands' ``--figure-format``, :func:`impactid.commandline.deliver`), else the path's suffix.

This module imports no matplotlib (nor numpy) when it is imported: ``impactid --help`` stays light.
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
import os
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, TypeVar

__all__ = ["FORMATS", "MEASURED", "OKABE_ITO", "PNG_DPI", "REGIME_COLOURS", "SIMULATED", "STYLE", "UNITLESS",
           "axis_label", "current_format", "figure_format", "figure_name", "new_figure", "number", "save_figure",
           "style", "styled"]

#: The formats a figure can be written in (``--figure-format``).
FORMATS = ("png", "svg", "pdf")
#: Resolution of PNG figures [dots per inch].
PNG_DPI = 200
#: The unit of a dimensionless quantity in an axis label.
UNITLESS = "[-]"

#: The Okabe & Ito (2008) palette, distinguishable with the common colour-vision deficiencies.
OKABE_ITO = {
    "blue": "#0072B2",
    "vermillion": "#D55E00",
    "green": "#009E73",
    "orange": "#E69F00",
    "sky blue": "#56B4E9",
    "reddish purple": "#CC79A7",
    "yellow": "#F0E442",
    "black": "#000000",
}
#: The colour cycle (``C0``, ``C1``, ... in a styled figure): Okabe–Ito, yellow last (faint on white).
CYCLE = ("#0072B2", "#D55E00", "#009E73", "#E69F00", "#56B4E9", "#CC79A7", "#000000", "#F0E442")
#: Measured data (dots): near-black.
MEASURED = "#333333"
#: A simulation or fitted model (lines): vermillion.
SIMULATED = OKABE_ITO["vermillion"]
#: The motion regimes of the regime maps and bifurcation diagrams.
REGIME_COLOURS = {"contact": OKABE_ITO["green"], "period-1": OKABE_ITO["blue"], "period-k": OKABE_ITO["orange"],
                  "irregular": OKABE_ITO["vermillion"]}

#: The rcParams of every figure of the package (:func:`style`).
STYLE: dict[str, Any] = {
    "font.size": 9.0,
    "axes.titlesize": 10.0,
    "axes.labelsize": 9.0,
    "xtick.labelsize": 8.0,
    "ytick.labelsize": 8.0,
    "legend.fontsize": 8.0,
    "figure.titlesize": 11.0,
    "axes.grid": True,
    "axes.grid.which": "major",
    "grid.alpha": 0.3,
    "grid.linewidth": 0.6,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "lines.linewidth": 1.4,
    "lines.markersize": 4.0,
    "legend.frameon": True,
    "legend.framealpha": 0.9,
    "legend.edgecolor": "0.8",
    "figure.constrained_layout.use": True,
    "figure.dpi": 100.0,
    "savefig.dpi": PNG_DPI,
    "mathtext.fontset": "dejavusans",
    "svg.fonttype": "none",
    "pdf.fonttype": 42,
    "image.cmap": "viridis",
}

F = TypeVar("F", bound=Callable[..., Any])

_FORMAT: contextvars.ContextVar[str | None] = contextvars.ContextVar("impactid_figure_format", default=None)


def _style_params() -> dict[str, Any]:
    from cycler import cycler

    return {**STYLE, "axes.prop_cycle": cycler(color=list(CYCLE))}


@contextlib.contextmanager
def style() -> Iterator[None]:
    """Draw (and save) figures in the package's style within the block (a matplotlib ``rc_context``).

    Most properties (fonts, colour cycle, grid) are read when an artist is created, so the whole
    figure must be built inside the block, not only saved there.
    """
    import matplotlib

    with matplotlib.rc_context(_style_params()):
        yield


def styled(func: F) -> F:
    """Decorate a function that builds a figure: it runs within :func:`style`."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        with style():
            return func(*args, **kwargs)

    return wrapper  # type: ignore[return-value]


def new_figure(nrows: int = 1, ncols: int = 1, *, size: tuple[float, float] = (6.4, 4.2), **subplots: Any):
    """A :class:`~matplotlib.figure.Figure` with constrained layout and its axes (a 2-D array).

    Call it within :func:`style`. ``subplots`` go to :meth:`~matplotlib.figure.Figure.subplots`
    (``sharex``, ...).
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False, **subplots)
    return fig, axes


def axis_label(quantity: str, unit: str | None, symbol: str | None = None) -> str:
    """An axis label: the quantity in words, its symbol in mathtext, the unit in brackets.

    Parameters
    ----------
    quantity : the quantity in words (``"indentation"``).
    unit : its unit (``"µm"``, mathtext allowed: ``"N s m$^{-(n+1)}$"``); ``None`` or ``"-"`` for a
        dimensionless quantity (``[-]``).
    symbol : its symbol in mathtext without the dollars (``r"\\delta"``), or None.

    Examples
    --------
    >>> axis_label("indentation", "µm", r"\\delta")
    'indentation $\\\\delta$ [µm]'
    >>> axis_label("coefficient of restitution", None, "e")
    'coefficient of restitution $e$ [-]'
    """
    text = quantity + (f" ${symbol}$" if symbol else "")
    return f"{text} {UNITLESS}" if unit in (None, "", "-") else f"{text} [{unit}]"


def number(value: float, digits: int = 4) -> str:
    """A number for a title or legend in mathtext: ``2.443e+10`` as ``$2.443 \\times 10^{10}$``.

    >>> number(2.443e10)
    '$2.443 \\times 10^{10}$'
    >>> number(0.5)
    '$0.5$'
    """
    text = f"{value:.{digits}g}"
    mantissa, _, exp = text.partition("e")
    if not exp:
        return f"${text}$"
    return f"${mantissa} \\times 10^{{{int(exp)}}}$"


@contextlib.contextmanager
def figure_format(fmt: str | None) -> Iterator[None]:
    """Save figures in ``fmt`` (``png``, ``svg`` or ``pdf``; None: leave it as it is) within the block."""
    if fmt is None:
        yield
        return
    token = _FORMAT.set(_checked(fmt))
    try:
        yield
    finally:
        _FORMAT.reset(token)


def current_format() -> str | None:
    """The format :func:`figure_format` set for the current block, or None."""
    return _FORMAT.get()


def _checked(fmt: str) -> str:
    fmt = str(fmt).lower().lstrip(".")
    if fmt not in FORMATS:
        raise ValueError(f"unknown figure format {fmt!r}; valid: {', '.join(FORMATS)}")
    return fmt


def figure_name(name: str | os.PathLike[str], fmt: str | None = None) -> str:
    """``name`` with the suffix of the figure format: ``fmt``, else :func:`current_format`, else its own.

    >>> figure_name("fig/landscape.png", "svg")
    'fig/landscape.svg'
    """
    fmt = fmt or current_format()
    return str(Path(name).with_suffix("." + _checked(fmt))) if fmt else str(name)


def save_figure(fig, path: str | os.PathLike[str], staged=None, fmt: str | None = None, **kwargs: Any) -> Path:
    """Save ``fig`` atomically (or staged in ``staged``, a :class:`~impactid._files.StagedFiles`).

    Parameters
    ----------
    fig : the figure.
    path : where to write it; its suffix is replaced by the format's.
    staged : the transaction to stage the file in, or None to write it now.
    fmt : ``png`` (at :data:`PNG_DPI` dpi), ``svg`` or ``pdf``; default: :func:`current_format`,
        else the suffix of ``path`` (``png`` without one).
    kwargs : further arguments of :meth:`~matplotlib.figure.Figure.savefig` (``dpi`` is fixed).

    Returns
    -------
    The path written (or to be written when ``staged`` commits).
    """
    from impactid._files import atomic_write

    suffix = Path(path).suffix.lstrip(".").lower()
    fmt = _checked(fmt or current_format() or (suffix if suffix in FORMATS else "png"))
    target = Path(path).with_suffix("." + fmt)
    kwargs.pop("dpi", None)
    metadata = {"svg": {"Date": None}, "pdf": {"CreationDate": None}}.get(fmt)  # byte-stable vector files

    def write(tmp: Path) -> None:
        with style():
            fig.savefig(tmp, format=fmt, dpi=PNG_DPI, metadata=metadata, **kwargs)

    if staged is not None:
        return staged.write_with(target, write)
    return atomic_write(target, write)
