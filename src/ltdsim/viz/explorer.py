"""A run's result as one self-contained interactive page: ``ltdsim view``.

The page is a Bokeh standalone document written with its JavaScript inline and its
interactions as CustomJS callbacks, so that the saved HTML file works offline in any
browser, with no server and nothing fetched. It shows the coupler force and deflection
along the train against time as heatmaps with a time and a coupler cursor, the force
profile along the train at the cursor's time, each coupler's force envelope, the chosen
coupler's force history and force-deflection loop, the lead vehicle's speed, the track
under it (grade and curvature) and, when the run recorded them, the brake-pipe and
brake-cylinder pressures. Panels whose variables the result lacks are left out and the
page says so.

Decimation keeps peaks: the time axis is cut into at most :func:`time_bins` bins, and
each bin keeps, per coupler (or vehicle), the two samples at which its value is largest
and smallest, in the order they occurred (:func:`extreme_samples`). A line drawn
through them at the bin's centre traces the signal's whole range in every bin, so no
peak is lost, and the page's size is bounded by :data:`MAX_VALUES` whatever the run's
length. Units: the result's are SI; the page shows kN, mm, km/h, bar, per mille and 1/km,
each axis labelled.
"""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np
import xarray as xr

from ltdsim.results.io import atomic_path, scenario_of

#: the variables the page draws from (those of them a result holds are read)
VIEW_VARIABLES = ("coupler_force", "coupler_deflection", "velocity", "position",
                  "speed_reference", "brake_pipe_pressure", "brake_cylinder_pressure",
                  "max_coupler_force", "min_coupler_force", "time_max_coupler_force",
                  "time_min_coupler_force")
#: the variables without which there is no page (the heatmap, profile and envelope)
NEEDED = ("coupler_force",)
#: the page's mark in its ``<head>``: ``ltdsim view`` writes over a file only if it has it
GENERATOR = "ltdsim view"
#: most float32 values of the per-coupler arrays the page holds (each couplers x time
#: bins: the force and deflection at each bin's two extreme samples, the two heatmaps,
#: and the two samples' places in the bin as 16-bit numbers, which count as one), 2.4 MB
#: before Bokeh's compression
MAX_VALUES = 600_000
#: per-coupler arrays the page holds, each couplers x time bins, in float32's size
_ARRAYS = 7
#: most time bins, whatever the train (a bin per pixel of a wide screen at most)
MAX_BINS = 2000
#: at most this many vehicles get a line in each brake-pressure plot
BRAKE_LINES = 5
#: the colours of compression (blue) to tension (red), ColorBrewer's RdBu (11 classes)
_PALETTE = ("#053061", "#2166ac", "#4393c3", "#92c5de", "#d1e5f0", "#f7f7f7", "#fddbc7",
            "#f4a582", "#d6604d", "#b2182b", "#67001f")


def _smooth(palette: tuple[str, ...], n: int = 255) -> tuple[str, ...]:
    """``palette`` interpolated linearly in RGB to ``n`` colours (a heatmap without
    bands)."""
    rgb = np.array([[int(c[k:k + 2], 16) for k in (1, 3, 5)] for c in palette], float)
    pos = np.linspace(0.0, len(palette) - 1.0, n)
    out = np.stack([np.interp(pos, np.arange(len(palette)), rgb[:, k]) for k in range(3)],
                   axis=1).round().astype(int)
    return tuple("#%02x%02x%02x" % tuple(c) for c in out)
_LINES = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e")


# ------------------------------------------------------------------------ decimation
def time_bins(n_time: int, n_couplers: int) -> int:
    """How many time bins the page has for ``n_time`` samples and ``n_couplers``
    couplers: every sample when they fit, else as many as :data:`MAX_VALUES` allows
    (and :data:`MAX_BINS` at most), at least 1."""
    fit = MAX_VALUES // (_ARRAYS * max(n_couplers, 1))
    return int(max(1, min(n_time, MAX_BINS, fit)))


def bin_edges(n_time: int, bins: int) -> np.ndarray:
    """Sample indices where each of ``bins`` bins of ``n_time`` samples starts, and
    ``n_time`` at the end (``bins + 1`` increasing integers; each bin holds at least one
    sample when ``bins <= n_time``)."""
    bins = max(1, min(bins, n_time))
    return np.linspace(0, n_time, bins + 1).round().astype(np.int64)


def extreme_samples(x: np.ndarray, edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The two samples of each bin that hold each column's smallest and largest value.

    Parameters
    ----------
    x : ndarray
        Samples, time x columns (any unit).
    edges : ndarray
        Bin edges as sample indices (:func:`bin_edges`).

    Returns
    -------
    first, second : ndarray of int
        Bins x columns: the sample index of the bin's extreme that comes first in time
        and of the one that comes second (the same index when the bin holds one sample,
        or its values are all equal). ``x[first]`` and ``x[second]`` hold each bin's
        minimum and maximum, so the decimated series keeps every column's extremes.
    """
    x = np.asarray(x)
    if x.ndim == 1:
        f, s = extreme_samples(x[:, None], edges)
        return f[:, 0], s[:, 0]
    bins = len(edges) - 1
    lo = np.empty((bins, x.shape[1]), dtype=np.int64)
    hi = np.empty_like(lo)
    size = edges[1] - edges[0]
    if bins and np.all(np.diff(edges) == size):  # equal bins: one reshape
        blocks = x[edges[0]:edges[-1]].reshape(bins, size, x.shape[1])
        start = edges[:-1, None]
        lo[:] = start + np.argmin(blocks, axis=1)
        hi[:] = start + np.argmax(blocks, axis=1)
    else:
        for b in range(bins):
            block = x[edges[b]:edges[b + 1]]
            lo[b] = edges[b] + np.argmin(block, axis=0)
            hi[b] = edges[b] + np.argmax(block, axis=0)
    return np.minimum(lo, hi), np.maximum(lo, hi)


def _take(x: np.ndarray, index: np.ndarray) -> np.ndarray:
    """``x[index[b, j], j]``: column j's sample at each bin's chosen index."""
    return np.take_along_axis(np.asarray(x), index, axis=0)


def _signed_extreme(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Elementwise the one of ``a`` and ``b`` larger in magnitude (sign kept)."""
    return np.where(np.abs(a) >= np.abs(b), a, b)


def minmax_line(t: np.ndarray, y: np.ndarray, edges: np.ndarray) -> tuple[np.ndarray, ...]:
    """A series ``y(t)`` (time, or time x columns) decimated for a line plot: each
    bin's two extreme samples at their own times (s), in time order, so that the line
    passes through every bin's largest and smallest value. Returns ``(x, y)``, 2 points
    a bin (``x`` time x columns for ``y`` of columns)."""
    first, second = extreme_samples(y, edges)
    if y.ndim == 1:
        xs = np.stack([t[first], t[second]], axis=1).ravel()
        return xs, np.stack([y[first], y[second]], axis=1).ravel()
    bins, k = first.shape
    xs = np.stack([t[first], t[second]], axis=1).reshape(2 * bins, k)
    return xs, np.stack([_take(y, first), _take(y, second)], axis=1).reshape(2 * bins, k)


def _centres(t: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Centre time of each bin: midway between its first and last sample, s."""
    return 0.5 * (t[edges[:-1]] + t[edges[1:] - 1])


# ---------------------------------------------------------------------- page's data
class PageData:
    """The decimated arrays of a result that the page holds (plain numpy, page units).

    Attributes
    ----------
    t : ndarray
        Sample times of the result, s.
    edges : ndarray
        Bin edges (sample indices); ``start`` and ``centre`` each bin's first sample's
        and centre time, s.
    index_a, index_b : ndarray of int
        Couplers x bins: each bin's first and second extreme sample of the coupler force
        (:func:`extreme_samples`), sample indices.
    force_a, force_b : ndarray
        Couplers x bins: the coupler force at those samples, kN.
    defl_a, defl_b : ndarray or None
        The coupler deflection at those same samples, mm (None: not recorded).
    force_map, defl_map : ndarray
        Couplers x bins: the bin's force (kN) and deflection (mm, None when not
        recorded) of largest magnitude, sign kept: the heatmaps.
    tension, compression : ndarray
        Per coupler its largest tension (>= 0) and compression (<= 0), kN: over every
        integration step where the result tracked the peaks, else over the samples.
    envelope_source : str
        Where the envelope comes from, in words.
    """

    def __init__(self, ds: xr.Dataset, bins: int | None = None):
        t = np.asarray(ds.time.values, dtype=float)
        force = np.asarray(ds.coupler_force.values, dtype=float)
        nc = force.shape[1]
        self.t = t
        self.edges = bin_edges(len(t), bins or time_bins(len(t), nc))
        self.start = t[self.edges[:-1]]
        self.centre = _centres(t, self.edges)
        first, second = extreme_samples(force, self.edges)
        self.index_a, self.index_b = first.T, second.T
        self.force_a = (_take(force, first) / 1e3).T
        self.force_b = (_take(force, second) / 1e3).T
        self.force_map = _signed_extreme(self.force_a, self.force_b)
        self.defl_a = self.defl_b = self.defl_map = None
        if "coupler_deflection" in ds:
            d = np.asarray(ds.coupler_deflection.values, dtype=float)
            self.defl_a = (_take(d, first) * 1e3).T
            self.defl_b = (_take(d, second) * 1e3).T
            lo, hi = extreme_samples(d, self.edges)
            self.defl_map = _signed_extreme(_take(d, lo), _take(d, hi)).T * 1e3
        if "max_coupler_force" in ds and "min_coupler_force" in ds:
            top = np.asarray(ds.max_coupler_force.values, dtype=float)
            low = np.asarray(ds.min_coupler_force.values, dtype=float)
            self.envelope_source = "over every integration step of the run"
        else:
            top, low = force.max(axis=0), force.min(axis=0)
            self.envelope_source = "over the recorded samples"
        self.tension = np.maximum(top, 0.0) / 1e3
        self.compression = np.minimum(low, 0.0) / 1e3

    @property
    def bins(self) -> int:
        """Number of time bins."""
        return len(self.edges) - 1

    @property
    def couplers(self) -> int:
        """Number of couplers."""
        return self.force_a.shape[0]

    def bin_width(self) -> float:
        """Typical width of a bin, s (the samples it holds times the sampling interval)."""
        dt = float(np.median(np.diff(self.t))) if len(self.t) > 1 else 0.0
        return float(np.median(np.diff(self.edges))) * dt if dt > 0 else 0.0


def head_track(ds: xr.Dataset, scenario) -> tuple[np.ndarray, np.ndarray] | None:
    """Grade (per mille, + uphill) and curvature (1/km, + turning left) of the track
    under the lead vehicle at each recorded sample, from the scenario's ``[track]`` and
    the lead vehicle's position; None when the result has no positions."""
    if "position" not in ds:
        return None
    from ltdsim.physics.alignment import alignment_of

    x = np.asarray(ds.position.values[:, 0], dtype=float)
    table = np.asarray(scenario.track.gradient, dtype=float).reshape(-1, 2)
    piece = np.clip(np.searchsorted(table[:, 0], x, side="right") - 1, 0, len(table) - 1)
    grade = table[piece, 1] * 1e3
    curvature = alignment_of(scenario.track).curvature(x) * 1e3
    return grade, curvature


def brake_vehicles(p: np.ndarray, count: int = BRAKE_LINES) -> list[int]:
    """Up to ``count`` vehicles (0-based), front to rear evenly spaced, among those whose
    pressure ``p`` (time x vehicle) is recorded (not all NaN)."""
    kept = np.flatnonzero(np.isfinite(p).any(axis=0))
    if len(kept) <= count:
        return kept.tolist()
    return kept[np.unique(np.linspace(0, len(kept) - 1, count).round().astype(int))].tolist()


# ------------------------------------------------------------------------ the page
def build_page(ds: xr.Dataset, source: str = "result", bins: int | None = None):
    """The page's Bokeh layout for result ``ds`` (read from the file named ``source``).

    Returns ``(document, data, notes)``: the Bokeh document to write, the
    :class:`PageData` it holds and the lines that say which panels are left out and
    why. The models the page's scripts and tests look up carry names: the sliders
    ``time_cursor`` and ``coupler_cursor``, the sources ``profile``, ``history``,
    ``loop`` and ``envelope``, the figures ``force_map``, ``deflection_map``,
    ``envelope_plot`` and ``history_plot``."""
    from bokeh.document import Document
    from bokeh.layouts import column, row
    from bokeh.models import CustomJS, Div, Slider

    data = PageData(ds, bins)
    notes: list[str] = []
    nc = data.couplers
    t0, t1 = float(data.t[0]), float(data.t[-1])
    worst = int(np.argmax(np.maximum(data.tension, -data.compression)))
    k0 = int(np.argmax(np.abs(data.force_map[worst])))
    time_cursor = Slider(start=t0, end=max(t1, t0 + 1e-9), value=float(data.centre[k0]),
                         step=max(data.bin_width(), 1e-6), title="time cursor (s)",
                         name="time_cursor", sizing_mode="stretch_width")
    coupler_cursor = Slider(start=1, end=max(nc, 2), value=worst + 1, step=1,
                            title="coupler cursor (1 = behind the lead)",
                            name="coupler_cursor", sizing_mode="stretch_width",
                            disabled=nc < 2)
    views = _Views(data, time_cursor, coupler_cursor)
    maps = [views.heatmap(data.force_map, "force_map", "coupler force (kN, + tension)",
                          "kN")]
    if data.defl_map is not None:
        maps.append(views.heatmap(data.defl_map, "deflection_map",
                                  "coupler deflection (mm, + draft)", "mm"))
    else:
        notes.append("coupler deflection: not recorded (solver.record leaves out "
                     "coupler_deflection), so no deflection heatmap and no "
                     "force-deflection loop")
    profile = views.profile()
    envelope = views.envelope()
    history = views.history()
    parts = [column(maps, sizing_mode="stretch_width"),
             row(profile, envelope, sizing_mode="stretch_width"),
             row(history, *([views.loop()] if data.defl_a is not None else []),
                 sizing_mode="stretch_width")]
    speed = views.speed(ds)
    if speed is not None:
        parts.append(speed)
    else:
        notes.append("speed: not recorded (solver.record leaves out velocity)")
    track, why = views.track(ds)
    if track is not None:
        parts.append(track)
    else:
        notes.append(why)
    brakes, why = views.brakes(ds)
    if brakes:
        parts.append(row(brakes, sizing_mode="stretch_width"))
    else:
        notes.append(why)
    readout = Div(text="", name="readout", sizing_mode="stretch_width",
                  styles={"font-size": "14px"})
    views.connect(readout)
    head = Div(text=_header(ds, data, source, notes), sizing_mode="stretch_width")
    sliders = row(time_cursor, coupler_cursor, sizing_mode="stretch_width")
    layout = column([head, sliders, readout, *parts], sizing_mode="stretch_width")
    doc = Document()
    doc.add_root(layout)
    doc.js_on_event("document_ready", views.ready)
    # (the moment the page is drawn, for a test or a reader to time it: ms since the
    # navigation started)
    doc.js_on_event("document_ready", CustomJS(
        code="window.ltdsim_ready_ms = performance.now();"))
    return doc, data, notes


def write_page(ds: xr.Dataset, path: str | Path, source: str = "result",
               bins: int | None = None) -> tuple[Path, PageData, list[str]]:
    """Write the page of result ``ds`` (read from ``source``, a file name shown on the
    page) to ``path``, atomically, with Bokeh's JavaScript inline (no server, nothing
    fetched). Returns ``(path, data, notes)`` (:func:`build_page`)."""
    from bokeh.embed import file_html
    from bokeh.resources import INLINE

    doc, data, notes = build_page(ds, source, bins)
    title = f"ltdsim view: {ds.attrs.get('scenario_name', 'result')} ({Path(source).name})"
    text = file_html(doc, INLINE, title)
    text = text.replace("<head>", f'<head>\n    <meta name="generator" content="{GENERATOR}">',
                        1)
    path = Path(path)
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return path, data, notes


def is_page(path: str | Path) -> bool:
    """Whether ``path`` is a page :func:`write_page` wrote (its generator mark in the
    first 4 kB)."""
    try:
        with open(path, "rb") as f:
            head = f.read(4096)
    except OSError:
        return False
    return f'<meta name="generator" content="{GENERATOR}">'.encode() in head


def _header(ds: xr.Dataset, data: PageData, source: str, notes: list[str]) -> str:
    """The page's heading, what it shows and how, and which panels are left out."""
    e = html.escape
    name = ds.attrs.get("scenario_name", "result")
    case = ds.attrs.get("case") or ""
    nv = ds.sizes.get("vehicle", data.couplers + 1)
    width = data.bin_width()
    dec = (f"every recorded sample is shown ({len(data.t):,} samples)" if data.bins ==
           len(data.t) else
           f"the {len(data.t):,} recorded samples are cut into {data.bins:,} time bins of "
           f"about {width:.3g} s; each bin keeps, for each coupler, the samples of its "
           "largest and smallest force (and the deflections there), so every peak "
           "survives; the heatmaps show each bin's value of largest magnitude")
    omitted = "".join(f"<li>{e(n)}</li>" for n in notes)
    return (
        f"<h2 style='margin:0.2em 0'>ltdsim view: {e(name)}{' [' + e(case) + ']' if case else ''}"
        f"</h2><p style='margin:0.2em 0'>{e(Path(source).name)}: {nv} vehicles, "
        f"{data.couplers} couplers, {data.t[-1] - data.t[0]:.6g} s recorded. "
        f"Drag the sliders, or click a heatmap (sets the time and the coupler), the "
        f"envelope or the profile (sets the coupler), or a time plot (sets the time). "
        f"Couplers count from 1, behind the lead vehicle. Decimation: {e(dec)}. The "
        f"envelope is {e(data.envelope_source)}.</p>"
        + (f"<p style='margin:0.2em 0'><b>Not shown</b>, the result lacks what they need:"
           f"</p><ul style='margin:0.2em 0'>{omitted}</ul>" if notes else ""))


def _legend_above(p) -> None:
    """Move figure ``p``'s legend above its frame, in one row (it hides no data)."""
    legend = p.legend[0]
    legend.orientation = "horizontal"
    legend.label_text_font_size = "11px"
    legend.padding = 2
    legend.margin = 0
    legend.border_line_alpha = 0.0
    p.center.remove(legend)
    p.add_layout(legend, "above")


class _Views:
    """The page's figures, the cursors they share, and the callbacks that join them."""

    def __init__(self, data: PageData, time_cursor, coupler_cursor):
        from bokeh.models import Range1d

        self.data = data
        self.time_cursor = time_cursor
        self.coupler_cursor = coupler_cursor
        lo, hi = float(data.t[0]), float(data.t[-1])
        self.x_range = Range1d(lo, hi if hi > lo else lo + 1.0)
        nc = data.couplers
        self.c_range = Range1d(nc + 0.5, 0.5)  # coupler 1 at the top
        self.time_spans: list = []  # vertical lines at the cursor's time
        self.coupler_spans: list = []  # lines at the cursor's coupler
        self.time_plots: list = []  # plots a click on which sets the time
        self.maps: list = []
        self.coupler_plots: list = []  # plots a click on which sets the coupler (x)

    # --------------------------------------------------------------- helpers
    def _coupler_axis(self, p) -> None:
        """Figure ``p``'s x axis counts couplers: whole numbers only."""
        from bokeh.models import BasicTicker

        p.xaxis.ticker = BasicTicker(min_interval=1)

    def _figure(self, title: str, x_label: str, y_label: str, height: int, **kw):
        from bokeh.plotting import figure

        p = figure(title=title, height=height, sizing_mode="stretch_width",
                   tools="pan,box_zoom,wheel_zoom,reset,save", active_scroll=None,
                   toolbar_location="right", min_border_left=60, **kw)
        p.xaxis.axis_label = x_label
        p.yaxis.axis_label = y_label
        p.title.text_font_size = "13px"
        p.toolbar.logo = None
        return p

    def _time_plot(self, title: str, y_label: str, height: int = 220):
        p = self._figure(title, "time (s)", y_label, height, x_range=self.x_range)
        self._time_span(p)
        self.time_plots.append(p)
        return p

    def _time_span(self, p) -> None:
        from bokeh.models import Span

        s = Span(location=self.time_cursor.value, dimension="height", line_color="black",
                 line_dash="dashed", line_width=1)
        p.add_layout(s)
        self.time_spans.append(s)

    def _coupler_span(self, p, dimension: str) -> None:
        from bokeh.models import Span

        s = Span(location=self.coupler_cursor.value, dimension=dimension,
                 line_color="black", line_dash="dotted", line_width=1.5)
        p.add_layout(s)
        self.coupler_spans.append(s)

    # --------------------------------------------------------------- panels
    def heatmap(self, values: np.ndarray, name: str, title: str, unit: str):
        """A couplers x time heatmap (``values`` couplers x bins, in ``unit``)."""
        from bokeh.models import BasicTicker, ColorBar, HoverTool, LinearColorMapper

        d = self.data
        p = self._figure(title + " along the train: each time bin's value of largest "
                         "magnitude", "time (s)", "coupler (1 = behind the lead)", 250,
                         x_range=self.x_range, y_range=self.c_range, name=name)
        lim = float(np.nanmax(np.abs(values))) if np.isfinite(values).any() else 1.0
        lim = lim or 1.0
        mapper = LinearColorMapper(palette=_smooth(_PALETTE), low=-lim, high=lim)
        t0 = float(d.t[0])
        dt = float(np.median(np.diff(d.t))) if len(d.t) > 1 else 1.0
        width = float(d.t[-1] - d.t[0]) + dt
        p.image(image=[values.astype(np.float32)], x=t0 - dt / 2, y=0.5, dw=width,
                dh=d.couplers, color_mapper=mapper, level="image")
        p.add_layout(ColorBar(color_mapper=mapper, title=unit, width=10), "right")
        p.add_tools(HoverTool(tooltips=[("time", "$x{0.0} s"), ("coupler", "$y{0}"),
                                        (unit, "@image{0.0}")]))
        p.grid.visible = False
        p.yaxis.ticker = BasicTicker(min_interval=1)
        self._time_span(p)
        self._coupler_span(p, "width")
        self.maps.append(p)
        return p

    def profile(self):
        """The force along the train in the cursor's time bin (its range in the bin),
        with the envelope behind it."""
        from bokeh.models import ColumnDataSource

        d = self.data
        k = self._bin(self.time_cursor.value)
        x = np.arange(1, d.couplers + 1)
        src = ColumnDataSource({"x": x, "hi": np.maximum(d.force_a[:, k], d.force_b[:, k]),
                                "lo": np.minimum(d.force_a[:, k], d.force_b[:, k])},
                               name="profile")
        p = self._figure("force profile at the time cursor (grey: the envelope)",
                         "coupler (1 = behind the lead)", "coupler force (kN, + tension)",
                         260, name="profile_plot")
        p.varea(x=x, y1=d.compression, y2=d.tension, color="#dddddd")
        p.varea(x="x", y1="lo", y2="hi", source=src, color=_PALETTE[9], alpha=0.35)
        p.line("x", "hi", source=src, color=_PALETTE[9], line_width=2,
               legend_label="largest in the bin")
        p.line("x", "lo", source=src, color=_PALETTE[1], line_width=2,
               legend_label="smallest in the bin")
        _legend_above(p)
        self._coupler_span(p, "height")
        self._coupler_axis(p)
        self.coupler_plots.append(p)
        self.profile_source = src
        return p

    def envelope(self):
        """Each coupler's largest tension and compression (kN)."""
        from bokeh.models import ColumnDataSource, HoverTool

        d = self.data
        src = ColumnDataSource({"coupler": np.arange(1, d.couplers + 1),
                                "tension_kN": d.tension, "compression_kN": d.compression,
                                "zero": np.zeros(d.couplers)}, name="envelope")
        p = self._figure("coupler-force envelope: max tension and compression",
                         "coupler (1 = behind the lead)", "coupler force (kN, + tension)",
                         260, name="envelope_plot")
        w = 0.8
        p.vbar(x="coupler", bottom="zero", top="tension_kN", width=w, source=src,
               color=_PALETTE[9], legend_label="max tension")
        p.vbar(x="coupler", bottom="compression_kN", top="zero", width=w, source=src,
               color=_PALETTE[1], legend_label="max compression")
        p.add_tools(HoverTool(tooltips=[("coupler", "@coupler"),
                                        ("max tension", "@tension_kN{0.0} kN"),
                                        ("max compression", "@compression_kN{0.0} kN")]))
        _legend_above(p)
        self._coupler_span(p, "height")
        self._coupler_axis(p)
        self.coupler_plots.append(p)
        return p

    def _coupler_series(self, j: int) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Coupler ``j``'s force (kN) and deflection (mm) at its bins' extreme samples,
        in time order, and their times (s): 2 points a bin."""
        d = self.data
        t = np.stack([d.t[d.index_a[j]], d.t[d.index_b[j]]], axis=1).ravel()
        f = np.stack([d.force_a[j], d.force_b[j]], axis=1).ravel()
        x = (None if d.defl_a is None
             else np.stack([d.defl_a[j], d.defl_b[j]], axis=1).ravel())
        return t, f, x

    def history(self):
        """The chosen coupler's force against time."""
        from bokeh.models import ColumnDataSource

        j = int(self.coupler_cursor.value) - 1
        t, f, _ = self._coupler_series(j)
        self.history_source = ColumnDataSource({"t": t, "force": f}, name="history")
        p = self._time_plot(f"coupler {j + 1}: force history", "coupler force (kN, + tension)",
                            260)
        p.name = "history_plot"
        p.line("t", "force", source=self.history_source, color=_LINES[0], line_width=1.2)
        self.history_plot = p
        return p

    def loop(self):
        """The chosen coupler's force against its deflection."""
        from bokeh.models import ColumnDataSource

        j = int(self.coupler_cursor.value) - 1
        _, f, x = self._coupler_series(j)
        self.loop_source = ColumnDataSource({"deflection": x, "force": f}, name="loop")
        k = self._bin(self.time_cursor.value)
        d = self.data
        self.loop_mark = ColumnDataSource({"deflection": [d.defl_a[j, k], d.defl_b[j, k]],
                                           "force": [d.force_a[j, k], d.force_b[j, k]]},
                                          name="loop_cursor")
        p = self._figure(f"coupler {j + 1}: force against deflection (dot: the time cursor)",
                         "coupler deflection (mm, + draft)", "coupler force (kN, + tension)",
                         260, name="loop_plot")
        p.line("deflection", "force", source=self.loop_source, color=_LINES[0],
               line_width=1.0, alpha=0.8)
        p.scatter("deflection", "force", source=self.loop_mark, size=9, color=_LINES[1])
        self.loop_plot = p
        return p

    def speed(self, ds: xr.Dataset):
        """The lead vehicle's speed (and the reference speed), km/h."""
        if "velocity" not in ds:
            return None
        d = self.data
        p = self._time_plot("speed of the lead vehicle", "speed (km/h)")
        x, v = minmax_line(d.t, np.asarray(ds.velocity.values[:, 0], float) * 3.6, d.edges)
        p.line(x, v, color=_LINES[0], line_width=1.5, legend_label="lead vehicle")
        if "speed_reference" in ds:
            x, r = minmax_line(d.t, np.asarray(ds.speed_reference.values, float) * 3.6,
                               d.edges)
            if np.isfinite(r).any():
                p.line(x, r, color="#777777", line_dash="dashed", line_width=1.2,
                       legend_label="reference")
        _legend_above(p)
        return p

    def track(self, ds: xr.Dataset):
        """Grade (per mille) and curvature (1/km) under the lead vehicle; ``(figure,
        "")`` or ``(None, why not)``."""
        from bokeh.models import LinearAxis, Range1d

        if "position" not in ds:
            return None, ("track under the train: not shown, positions not recorded "
                          "(solver.record leaves out position)")
        try:
            sc = scenario_of(ds)
        except Exception as exc:  # noqa: BLE001 - a scenario this version cannot read
            first = (str(exc).splitlines() or [type(exc).__name__])[0]
            return None, f"track under the train: its scenario cannot be read ({first})"
        d = self.data
        grade, curv = head_track(ds, sc)
        p = self._time_plot("track under the lead vehicle: grade (left axis) and curvature "
                            "(right axis)", "grade (per mille, + uphill)")
        x, g = minmax_line(d.t, grade, d.edges)
        _, c = minmax_line(d.t, curv, d.edges)
        glim = max(float(np.abs(g).max()), 1.0) * 1.15
        clim = max(float(np.abs(c).max()), 0.1) * 1.15
        p.y_range = Range1d(-glim, glim)
        p.extra_y_ranges = {"curv": Range1d(-clim, clim)}
        p.add_layout(LinearAxis(y_range_name="curv",
                                axis_label="curvature (1/km, + left)"),
                     "right")
        p.line(x, g, color=_LINES[2], line_width=1.8, legend_label="grade")
        p.line(x, c, color=_LINES[3], line_width=1.4, y_range_name="curv",
               legend_label="curvature")
        _legend_above(p)
        return p, ""

    def brakes(self, ds: xr.Dataset):
        """Brake-pipe and brake-cylinder pressures (bar, gauge) at a few vehicles;
        ``(figures, "")`` or ``([], why not)``."""
        d = self.data
        out = []
        for name, title in (("brake_pipe_pressure", "brake-pipe pressure"),
                            ("brake_cylinder_pressure", "brake-cylinder pressure")):
            if name not in ds:
                continue
            p_all = np.asarray(ds[name].values, dtype=float)
            chosen = brake_vehicles(p_all)
            if not chosen:
                continue
            p = self._time_plot(f"{title} (gauge)", "pressure (bar, gauge)", 240)
            x, y = minmax_line(d.t, p_all[:, chosen] / 1e5, d.edges)
            for k, v in enumerate(chosen):
                p.line(x[:, k], y[:, k], color=_LINES[k % len(_LINES)], line_width=1.4,
                       legend_label=f"vehicle {v + 1}")
            _legend_above(p)
            out.append(p)
        if out:
            return out, ""
        model = ds.attrs.get("brake_model", "")
        why = ("brake-pipe and brake-cylinder pressures: not in this result (the fluid "
               "air brake, brake.model = \"fluid\", records them"
               + (f"; this run's brake model is {model}" if model else "")
               + ", or solver.record left them out)")
        return [], why

    # --------------------------------------------------------------- callbacks
    def _bin(self, t: float) -> int:
        """The time bin holding time ``t`` (s)."""
        k = int(np.searchsorted(self.data.start, t, side="right")) - 1
        return min(max(k, 0), self.data.bins - 1)

    def connect(self, readout) -> None:
        """Join the cursors to the plots: the sliders update the profile, the chosen
        coupler's history and loop, the cursor lines and the readout; clicks set the
        sliders."""
        from bokeh.events import Tap
        from bokeh.models import CustomJS

        d = self.data
        f32 = np.float32
        args = dict(
            ts=self.time_cursor, cs=self.coupler_cursor, B=d.bins, NC=d.couplers,
            start=d.start.astype(float), centre=d.centre.astype(float),
            **_sample_clock(d.t), edge=d.edges[:-1].astype(np.int32),
            oa=_offsets(d.index_a, d.edges), ob=_offsets(d.index_b, d.edges),
            fa=d.force_a.astype(f32).ravel(), fb=d.force_b.astype(f32).ravel(),
            da=None if d.defl_a is None else d.defl_a.astype(f32).ravel(),
            db=None if d.defl_b is None else d.defl_b.astype(f32).ravel(),
            ten=d.tension.astype(float), com=d.compression.astype(float),
            prof=self.profile_source, hist=self.history_source,
            hplot=self.history_plot, loop=getattr(self, "loop_source", None),
            lmark=getattr(self, "loop_mark", None), lplot=getattr(self, "loop_plot", None),
            tspans=self.time_spans, cspans=self.coupler_spans, readout=readout,
        )
        update = CustomJS(args=args, code=_UPDATE_JS)
        self.time_cursor.js_on_change("value", update)
        self.coupler_cursor.js_on_change("value", update)
        self.ready = update  # (run once as the page loads: the readout's first text)
        put = ("const put = (s, v) => { const c = Math.min(Math.max(v, s.start), s.end); "
               "if (s.value !== c) { s.value = c; } };\n")
        for p in self.maps:
            p.js_on_event(Tap, CustomJS(args=dict(ts=self.time_cursor, cs=self.coupler_cursor),
                                        code=put + "put(ts, cb_obj.x); "
                                                   "put(cs, Math.round(cb_obj.y));"))
        for p in self.coupler_plots:
            p.js_on_event(Tap, CustomJS(args=dict(cs=self.coupler_cursor),
                                        code=put + "put(cs, Math.round(cb_obj.x));"))
        for p in self.time_plots:
            p.js_on_event(Tap, CustomJS(args=dict(ts=self.time_cursor),
                                        code=put + "put(ts, cb_obj.x);"))


def _sample_clock(t: np.ndarray) -> dict:
    """How the page's script finds sample i's time (s): ``t0 + i dt`` for evenly spaced
    samples (an ltdsim result's), so that the page does not carry a time for every
    sample; the times themselves (``tsamp``) only for a result whose samples are not
    evenly spaced."""
    n = len(t)
    dt = float(t[-1] - t[0]) / (n - 1) if n > 1 else 0.0
    even = n < 2 or np.allclose(t, t[0] + np.arange(n) * dt, rtol=0.0,
                                atol=1e-9 * max(1.0, float(np.abs(t).max())))
    return {"t0": float(t[0]), "dt": dt, "tsamp": None if even else t.astype(float)}


def _offsets(index: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Couplers x bins sample indices as their places in their bins, flattened, in the
    smallest unsigned integers that hold them (16 bits unless a bin is longer)."""
    off = index - edges[None, :-1]
    kind = np.uint16 if off.size == 0 or off.max() < 2 ** 16 else np.uint32
    return off.astype(kind).ravel()


#: the cursors' callback: the time bin and coupler chosen, then everything they show
_UPDATE_JS = """
const t = ts.value;
const j = Math.min(Math.max(Math.round(cs.value), 1), NC) - 1;
let lo = 0, hi = B - 1;  // the bin whose start is the last at or before t
while (lo < hi) { const m = (lo + hi + 1) >> 1; if (start[m] <= t) { lo = m; } else { hi = m - 1; } }
const k = lo;
const ph = new Float64Array(NC), pl = new Float64Array(NC);
for (let i = 0; i < NC; i++) {
  const a = fa[i * B + k], b = fb[i * B + k];
  ph[i] = Math.max(a, b); pl[i] = Math.min(a, b);
}
prof.data = {x: prof.data.x, hi: ph, lo: pl};
if (hist.tags.length === 0 || hist.tags[0] !== j) {
  const hy = new Float64Array(2 * B), ht = new Float64Array(2 * B);
  for (let m = 0; m < B; m++) {
    hy[2 * m] = fa[j * B + m]; hy[2 * m + 1] = fb[j * B + m];
    const i1 = edge[m] + oa[j * B + m], i2 = edge[m] + ob[j * B + m];
    ht[2 * m] = tsamp === null ? t0 + i1 * dt : tsamp[i1];
    ht[2 * m + 1] = tsamp === null ? t0 + i2 * dt : tsamp[i2];
  }
  hist.data = {t: ht, force: hy};
  hist.tags = [j];
  hplot.title.text = `coupler ${j + 1}: force history`;
  if (loop !== null) {
    const lx = new Float64Array(2 * B);
    for (let m = 0; m < B; m++) { lx[2 * m] = da[j * B + m]; lx[2 * m + 1] = db[j * B + m]; }
    loop.data = {deflection: lx, force: hy};
    lplot.title.text = `coupler ${j + 1}: force against deflection (dot: the time cursor)`;
  }
}
if (lmark !== null) {
  lmark.data = {deflection: [da[j * B + k], db[j * B + k]],
                force: [fa[j * B + k], fb[j * B + k]]};
}
for (const s of tspans) { s.location = t; }
for (const s of cspans) { s.location = j + 1; }
const f1 = Math.min(fa[j * B + k], fb[j * B + k]), f2 = Math.max(fa[j * B + k], fb[j * B + k]);
const kn = (x) => x.toFixed(1);
let text = `<b>time cursor ${t.toFixed(2)} s</b> (time bin ${k + 1} of ${B}, centred at ` +
           `${centre[k].toFixed(2)} s) &middot; <b>coupler ${j + 1}</b>: force in the bin ` +
           (f1 === f2 ? `${kn(f1)} kN` : `${kn(f1)} to ${kn(f2)} kN`);
if (da !== null) {
  const d1 = da[j * B + k], d2 = db[j * B + k];
  text += `, deflection there ${d1.toFixed(1)}` + (d1 === d2 ? '' : ` and ${d2.toFixed(1)}`) + ' mm';
}
text += ` &middot; envelope +${kn(ten[j])} / ${kn(com[j])} kN`;
readout.text = text;
"""
