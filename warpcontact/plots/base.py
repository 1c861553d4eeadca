"""What every figure shares: the paper's colours, a Figure on an Agg canvas of its own (nothing
touches pyplot or the global backend, so the figures are safe to call from a library, a test or a
thread), the SI prefix that puts an axis in the data's own scale, and the PNG written whole or not
at all."""

from __future__ import annotations

import io
import math
import os
import secrets
from pathlib import Path

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

#: The paper's colours: A_c blue, A_st orange, A_adh yellow.
CONTACT_COLOR = "#0072BD"
STICK_COLOR = "#D95319"
ADHESIVE_COLOR = "#EDB120"

#: Line colours of a sweep's series: the paper's (MATLAB's) colour order.
SERIES_COLORS = (CONTACT_COLOR, STICK_COLOR, ADHESIVE_COLOR, "#7E2F8E", "#77AC30", "#4DBEEE", "#A2142F")


def _figure(figsize, layout="constrained") -> Figure:
    fig = Figure(figsize=figsize, layout=layout)
    FigureCanvasAgg(fig)  # an Agg canvas of its own: draw(), buffer_rgba() and savefig() work
    return fig


#: SI prefixes for an axis in the data's own scale: factor -> prefix (micro: the micro sign, U+00B5).
_PREFIXES = ((1e9, "G"), (1e6, "M"), (1e3, "k"), (1.0, ""), (1e-3, "m"), (1e-6, "\u00b5"), (1e-9, "n"),
             (1e-12, "p"), (1e-15, "f"))


def si_scale(values, unit: str):
    """(factor, label) putting ``values`` [unit] in the prefix where the largest |value| lies in
    [0.5, 500): an nN curve in nN, a 0.6 nm approach in nm, 4.4 GPa in GPa (``value / factor`` is
    drawn)."""
    peak = max((abs(float(v)) for v in values if v is not None and math.isfinite(float(v))), default=0.0)
    for factor, prefix in _PREFIXES:
        if peak >= 0.5 * factor:
            return factor, prefix + unit
    return _PREFIXES[-1][0], _PREFIXES[-1][1] + unit


def save(fig: Figure, path, dpi=None) -> None:
    """Write ``fig`` as a PNG at ``path``, whole or not at all (a temporary file, then os.replace)."""
    path = Path(path)
    buf = io.BytesIO()
    # tight: the canvas grows to hold text placed outside it (the case caption of `figure`)
    fig.savefig(buf, format="png", dpi=dpi if dpi is not None else "figure", bbox_inches="tight", pad_inches=0.08)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.parent / f".{path.name}.{secrets.token_hex(6)}.tmp"
    # O_EXCL: a name of our own; mode 0666 less the umask, an ordinary file's mode (not mkstemp's 0600)
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(buf.getvalue())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
