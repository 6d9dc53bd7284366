"""The figure helpers: parallel rendering gives the same PNG bytes as one by one; fixed layouts in inches."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from pinid.report.figures import fixed_layout, new_figure, render_pngs
from pinid.report.plot_identification import error_bars, recorded_motion, torque_comparison


def _recipes():
    t = np.arange(3000) / 1000.0
    q = np.sin(np.outer(t, [1.0, 2.0, 3.0]))
    joints = ["a", "b", "c"]
    metrics = {
        "ols": {"per_joint": {j: {"mean_abs": 0.1, "p5_abs": 0.01, "p95_abs": 0.3} for j in joints},
                "all": {"mean_abs": 0.1, "p5_abs": 0.01, "p95_abs": 0.3}},
    }  # fmt: skip
    return {
        "torque": (torque_comparison, (t, q, {"m": q + 0.01}, joints), {"title": "torque"}),
        "motion": (recorded_motion, (t, q, q, joints), {"title": "motion"}),
        "errors": (error_bars, (metrics,), {"title": "errors"}),
    }


@pytest.mark.slow  # 3–4.5 s on a quiet 2-core machine: the quick run (-m "not slow") stays within 3 min
def test_pool_and_one_by_one_give_the_same_bytes():
    recipes = _recipes()
    pooled = render_pngs(recipes, workers=2)
    single = render_pngs(recipes, workers=1)
    assert list(pooled) == list(recipes)
    assert pooled == single
    assert all(png.startswith(b"\x89PNG") for png in pooled.values())


@pytest.mark.parametrize("rows, cols", [(1, 1), (3, 2), (5, 3)])
def test_fixed_layout_margins_and_gaps_are_in_inches(rows, cols):
    fig, axes = new_figure(rows, cols, figsize=(8.0, 2.0 * rows), squeeze=False)
    fixed_layout(fig, left=0.9, right=0.2, bottom=0.5, top=0.4, hspace=0.3, wspace=0.6)
    w, h = fig.get_size_inches()
    boxes = [[axes[r, c].get_position() for c in range(cols)] for r in range(rows)]
    assert boxes[0][0].x0 * w == pytest.approx(0.9)
    assert (1 - boxes[0][-1].x1) * w == pytest.approx(0.2)
    assert boxes[-1][0].y0 * h == pytest.approx(0.5)
    assert (1 - boxes[0][0].y1) * h == pytest.approx(0.4)
    if rows > 1:
        assert (boxes[0][0].y0 - boxes[1][0].y1) * h == pytest.approx(0.3)
    if cols > 1:
        assert (boxes[0][1].x0 - boxes[0][0].x1) * w == pytest.approx(0.6)


@pytest.mark.slow  # 5 s of CPU (docs/benchmarks.md, Test suite)
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="worker processes are forked on Linux only")
def test_workers_started_ahead_draw_the_same_bytes_and_are_used_once():
    import pinid.report.figures as figures

    recipes = _recipes()
    figures.start_figure_workers(2)
    started = figures._started
    assert started is not None
    pooled = render_pngs(recipes)
    assert figures._started is None
    assert pooled == render_pngs(recipes, workers=1)
    figures.start_figure_workers(2)
    assert figures._started is not started
    assert render_pngs(recipes, workers=1) == pooled  # an explicit count shuts the started workers down
    assert figures._started is None


def _no_figure(message: str):
    raise ValueError(message)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="worker processes are forked on Linux only")
def test_a_recipe_failing_in_the_workers_started_ahead_raises_here_and_they_stop():
    import pinid.report.figures as figures

    figures.start_figure_workers(2)
    loader = figures._started
    with pytest.raises(ValueError, match="no such figure"):
        render_pngs({"bad": (_no_figure, ("no such figure",), {})})
    assert figures._started is None
    loader._process.join(timeout=10)
    assert loader._process.exitcode == 0


def _torque_recipes(methods=("ols", "wls", "sdp")):
    """Torque figures of several methods on one recording, keyed as the report's (``torque_<method>``)."""
    t = np.arange(4000) / 1000.0
    measured = np.column_stack([np.sin(t), 3 * np.cos(2 * t)]) + 0.1 * np.random.default_rng(0).normal(size=(4000, 2))
    out = {}
    for k, m in enumerate(methods):
        pred = measured * (1 + 0.05 * k) + 0.2 * k
        out[f"torque_{m}"] = (
            torque_comparison,
            (t, measured, {m: pred}, ["hip", "knee"]),
            {"title": f"{m}: torque", "filtered": measured * 0.99, "units": ["N·m", "N·m"], "window": 3.0},
        )
    return out


def test_png_bytes_have_the_pixels_of_savefig():
    """Issue 35: the figures skip savefig's slow RGBA encoding; what a reader sees is the same."""
    import io

    from PIL import Image

    from pinid.report.figures import DPI, png_bytes

    fn, args, kwargs = _recipes()["torque"]
    ours = Image.open(io.BytesIO(png_bytes(fn(*args, **kwargs))))
    buf = io.BytesIO()
    fn(*args, **kwargs).savefig(buf, format="png", dpi=DPI)
    theirs = Image.open(buf)
    assert ours.mode == "RGB" and ours.size == theirs.size
    np.testing.assert_array_equal(np.asarray(ours), np.asarray(theirs.convert("RGB")))


def test_one_torque_figure_redrawn_per_method_gives_the_bytes_of_new_figures():
    from pinid.report.figures import figure_png
    from pinid.report.plot_identification import torque_pngs

    recipes = _torque_recipes()
    fresh = [figure_png(fn(*args, **kw)) for fn, args, kw in recipes.values()]
    _, (t, measured, _, joints), kw = recipes["torque_ols"]
    predicted = {m: next(iter(args[2].values())) for m, (_, args, _) in zip(("ols", "wls", "sdp"), recipes.values())}
    titles = {m: f"{m}: torque" for m in predicted}
    rest = {k: v for k, v in kw.items() if k != "title"}
    assert torque_pngs(t, measured, predicted, joints, titles=titles, **rest) == fresh


@pytest.mark.slow  # 5-9 s of CPU (docs/benchmarks.md, Test suite)
@pytest.mark.parametrize("workers, count", [(1, 1), (2, 2), (4, 3)])
def test_grouped_torque_figures_give_the_same_bytes(workers, count):
    """One worker redraws one torque figure for every method; more workers share the methods (the
    groups that finish first by the cost model: 3 torque figures and 2 others on 2 workers: 2 groups)."""
    from pinid.report.markdown import grouped_recipes

    recipes = {**_torque_recipes(), **{k: v for k, v in _recipes().items() if k != "torque"}}
    grouped = grouped_recipes(recipes, workers)
    groups = [k for k in grouped if isinstance(k, tuple)]
    assert sorted(sum(map(list, groups), [])) == sorted(k for k in recipes if k.startswith("torque_"))
    assert len(groups) == count
    expected = render_pngs(recipes, workers=1)
    assert render_pngs(grouped, workers=1) == expected
    if sys.platform.startswith("linux"):
        assert render_pngs(grouped, workers=2) == expected


def test_torque_figure_draws_the_prediction_above_the_measurements_and_both_errors():
    """Issue 33: the prediction in the method's colour above the raw (light) and low-passed (thin) torque;
    the error panel has the raw and the filtered error, labelled; the legend is outside every panel."""
    from matplotlib.colors import to_hex

    from pinid.report.colors import method_color

    fn, args, kw = _torque_recipes(("sdp",))["torque_sdp"]
    fig = fn(*args, **kw)
    top, bottom = fig.axes[0], fig.axes[1]
    lines = {ln.get_label(): ln for ln in top.get_lines()}
    pred, raw, low = lines["sdp: predicted"], lines["measured (as recorded)"], lines["measured, low-passed"]
    assert pred.get_zorder() > max(raw.get_zorder(), low.get_zorder())
    assert to_hex(pred.get_color()) == to_hex(method_color("sdp"))
    assert low.get_linewidth() < pred.get_linewidth()
    errors = [ln.get_label() for ln in bottom.get_lines() if not ln.get_label().startswith("_")]
    assert errors == ["sdp: error, raw", "sdp: error, filtered"]
    assert all(ax.get_legend() is None for ax in fig.axes) and len(fig.legends) == 1
    legend_box = fig.legends[0].get_window_extent(fig.canvas.get_renderer())
    assert legend_box.y0 >= top.get_window_extent().y1  # above the first panel: it covers no data


def test_parameter_plausibility_marks_sigma_truth_and_inconsistent_methods():
    """The parameter figure: one row per base parameter, values divided by the natural scale; a ±2σ bar
    where σ is known (none for a metaheuristic); the URDF and the truth; an inconsistent method hollow."""
    from matplotlib.colors import to_hex

    from pinid.report.colors import method_color
    from pinid.report.plot_parameters import parameter_plausibility

    names = ["hip.mx", "hip.Iyy", "hip.fv"]
    scale = [2.0, 0.5, 1.0]
    estimates = {
        "sdp": {"value": [1.0, 0.25, 0.3], "std": [0.1, 0.01, 0.02], "consistent": True},
        "pso": {"value": [1.2, -0.1, 0.35], "std": [np.nan] * 3, "consistent": False},
    }
    fig = parameter_plausibility(names, [1.1, 0.2, 0.25], scale, estimates, truth=[1.0, 0.25, None], title="p")
    ax = fig.axes[0]
    assert [t.get_text() for t in ax.get_yticklabels()] == names
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert labels == ["URDF", "truth", "sdp", "pso (not physically consistent)"]
    dots = {ln.get_label().split(" (")[0]: ln for ln in ax.get_lines()}
    np.testing.assert_allclose(dots["sdp"].get_xdata(), [0.5, 0.5, 0.3])  # divided by the natural scale
    np.testing.assert_allclose(dots["URDF"].get_xdata(), [0.55, 0.4, 0.25])
    assert np.isnan(dots["truth"].get_xdata()[2])
    assert to_hex(dots["pso"].get_markerfacecolor()) == "#ffffff"  # hollow: not physically consistent
    assert to_hex(dots["sdp"].get_markerfacecolor()) == to_hex(method_color("sdp"))
    bars = [c for c in ax.collections if c.get_segments()]
    assert len(bars) == 1 and len(bars[0].get_segments()) == 3  # ±2σ for sdp only, none for pso
    half = [abs(seg[1][0] - seg[0][0]) / 2 for seg in bars[0].get_segments()]
    np.testing.assert_allclose(half, [0.1, 0.04, 0.04])  # 2σ / scale


def test_envelope_keeps_every_runs_first_minimum_and_maximum_in_time_order():
    """Issue 35: a thinned line covers the pixels of every sample: each run keeps its extremes."""
    from pinid.report.figures import envelope

    rng = np.random.default_rng(0)
    n, columns = 26_001, 950
    t = np.arange(n) / 5000.0
    y = np.cumsum(rng.normal(size=n))
    y[[5, 12_345, n - 1]] = [80.0, -90.0, 70.0]  # single-sample spikes that every 13th sample would miss
    te, ye = envelope(t, y, columns)
    assert len(te) <= 2 * columns and np.all(np.diff(te) > 0)
    idx = np.searchsorted(t, te)
    np.testing.assert_array_equal(y[idx], ye)  # samples of the line, not new points
    starts = np.linspace(0, n, columns + 1).astype(int)
    for a, b in zip(starts[:-1], starts[1:]):
        kept = idx[(idx >= a) & (idx < b)]
        assert a + np.argmin(y[a:b]) in kept and a + np.argmax(y[a:b]) in kept
        assert len(kept) <= 2
    assert {80.0, -90.0, 70.0} <= set(ye)
    short = np.arange(10.0)
    assert envelope(short, short, 5)[1] is not None and len(envelope(short, short, 5)[1]) == 10  # no thinning
    gap = y.copy()
    gap[100] = np.nan  # a gap stays a gap: drawn as recorded
    assert len(envelope(t, gap, columns)[1]) == n


def _panels(plt):
    fig, axes = plt.subplots(3, 1, figsize=(6, 6), sharex=True)
    t = np.linspace(0.0, 7.3, 500)
    axes[0].plot(t, np.sin(t) * 3.7)
    axes[1].plot(t, np.exp(t))
    axes[1].set_yscale("log")
    axes[2].plot(t, 100 * np.cos(3 * t))
    axes[2].set_yticks([-100, 0, 50])
    fig.tight_layout()
    return fig


def test_ticks_in_view_draw_the_same_pixels_with_fewer_ticks():
    """Issue 35: ticks outside the view are never drawn; without their objects the picture is the same."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.figure
    import matplotlib.pyplot as plt

    from pinid.report.figures import DPI, ticks_in_view

    real = matplotlib.figure.Figure.tight_layout

    def tight(self, *args, **kwargs):  # wrapped before the layout pass, as new_figure does
        ticks_in_view(self)
        return real(self, *args, **kwargs)

    def drawn(wrap: bool):
        matplotlib.figure.Figure.tight_layout = tight if wrap else real
        try:
            fig = _panels(plt)
        finally:
            matplotlib.figure.Figure.tight_layout = real
        fig.set_dpi(DPI)
        fig.canvas.draw()
        pixels = np.asarray(fig.canvas.buffer_rgba()).copy()
        ticks = sum(len(a.majorTicks) + len(a.minorTicks) for ax in fig.axes for a in (ax.xaxis, ax.yaxis))
        plt.close(fig)
        return pixels, ticks

    plain, plain_ticks = drawn(False)
    ours, our_ticks = drawn(True)
    np.testing.assert_array_equal(ours, plain)
    assert our_ticks < plain_ticks


def test_ticks_in_view_follow_the_view_and_the_locator_params():
    import matplotlib

    matplotlib.use("Agg")
    from pinid.report.figures import png_bytes

    fig, ax = new_figure()
    ax.plot([0.0, 10.0], [0.0, 1.0])
    png_bytes(fig)
    assert list(ax.get_xticks()) == [0.0, 2.0, 4.0, 6.0, 8.0, 10.0]
    ax.set_xlim(0.0, 100.0)
    png_bytes(fig)
    assert list(ax.get_xticks()) == [0.0, 20.0, 40.0, 60.0, 80.0, 100.0]
    ax.locator_params(axis="x", nbins=2)
    png_bytes(fig)
    assert list(ax.get_xticks()) == [0.0, 50.0, 100.0]
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_figures_without_pyplot_give_the_bytes_of_pyplot_figures(monkeypatch):
    """Issue 45: a drawing worker makes its figures without pyplot (figures._BARE), the same pixels."""
    import pinid.report.figures as figures

    recipes = _recipes()
    with_pyplot = {k: figures._render(r) for k, r in recipes.items()}
    monkeypatch.setattr(figures, "_BARE", True)
    fig, _ = figures.new_figure(2, 1, figsize=(3, 2), sharex=True, gridspec_kw={"height_ratios": [2, 1]})
    assert fig.canvas.manager is None and len(fig.axes) == 2  # not one of pyplot's figures
    assert {k: figures._render(r) for k, r in recipes.items()} == with_pyplot


def _worker_state():
    import pinid.report.figures as figures

    fig, _ = figures.new_figure()
    return [figures._BARE, fig.canvas.manager is None, "matplotlib.figure" in sys.modules]


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="worker processes are forked on Linux only")
def test_drawing_workers_make_figures_without_pyplot():
    """Issue 45: the process that forks the drawing workers loads matplotlib (without pyplot unless its parent
    had it) and draws a figure once (fonts loaded) before it forks them; their figures are not pyplot's."""
    import pinid.report.figures as figures

    figures.start_figure_workers(2)
    loader = figures._started
    try:
        out = loader.map(figures._render, [(_worker_state, (), {})] * 2)
    finally:
        loader.shutdown()
        figures._started = None
    assert out == [[True, True, True]] * 2


@pytest.mark.parametrize("kind", ["torque", "overlay", "motion"])
def test_time_series_lines_keep_each_pixel_columns_minimum_and_maximum(kind):
    """Issue 45: a long trace is drawn as its envelope (figures.envelope): per run of samples (about one pixel
    column) the drawn line reaches the original's minimum and maximum, so spikes stay; at most max_points."""
    from pinid.report.plot_identification import prediction_overlay

    rng = np.random.default_rng(1)
    n, max_points = 45_000, 1_600
    t = np.arange(n) / 5000.0
    y = np.column_stack([np.cumsum(rng.normal(size=n)), np.sin(t) + 0.01 * rng.normal(size=n)])
    y[[7, 22_222, n - 2], 0] = [500.0, -400.0, 300.0]  # one-sample spikes that every 28th sample would miss
    if kind == "torque":
        fig = torque_comparison(t, y, {"ols": 0.5 * y}, ["a", "b"], window=None, max_points=max_points)
        line = fig.axes[0].lines[0]  # the measured torque of joint a
    elif kind == "overlay":
        fig = prediction_overlay(t, y, {"ols": y, "sdp": 0.5 * y}, ["a", "b"], reference="ols", window=None)
        max_points = 1_000
        line = fig.axes[0].lines[0]
    else:
        fig = recorded_motion(t, y, None, ["a", "b"], window=None, max_points=max_points)
        line = fig.axes[0].lines[0]
    x, drawn = np.asarray(line.get_xdata()), np.asarray(line.get_ydata())
    assert len(drawn) <= max_points
    runs = max_points // 2
    starts = np.linspace(0, n, runs + 1).astype(int)
    idx = np.searchsorted(t, x)
    np.testing.assert_array_equal(y[idx, 0], drawn)  # samples of the trace, in time order
    assert np.all(np.diff(idx) > 0)
    for a, b in zip(starts[:-1], starts[1:]):
        kept = drawn[(idx >= a) & (idx < b)]
        assert kept.min() == y[a:b, 0].min() and kept.max() == y[a:b, 0].max()
    assert {500.0, -400.0, 300.0} <= set(drawn)


def test_wearer_torque_figure_draws_each_model_in_its_own_colour():
    """Issue 47: torque_wearer.png's three models (exo + identified wearer, + table wearer, exo alone) had colours
    chosen from their names, two of them the same green; each has its own now, none a grey of the measurements."""
    import matplotlib.colors as mc

    from pinid.report.wearer import MODELS, torque_figure

    t = np.linspace(0, 2, 50)
    tau = np.c_[np.sin(t), np.cos(t)]
    curves = {"t": t, "measured": tau, "predicted": {w: tau + k for k, w in enumerate(MODELS)}, "joints": ["a", "b"]}
    fig = torque_figure(curves)
    colours = {ln.get_label(): mc.to_hex(ln.get_color()) for ln in fig.axes[0].get_lines()}
    predicted = [colours[f"{MODELS[w]}: predicted"] for w in MODELS]
    assert len(set(predicted)) == 3 and colours["measured (as recorded)"] not in predicted, colours
