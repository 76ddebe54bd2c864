"""The stress map is a figure a person reads: sized to its content, fonts of at least 8 pt, the
legend outside the data axes, no tick labels printed over each other (issue #29)."""

from types import SimpleNamespace

import pytest

from harness.studies.stress import report
from harness.studies.stress.run import MapRow

LABELS = [("inhouse", "rk4"), ("inhouse", "euler"), ("inhouse", "DOP853"), ("mujoco", "Euler"), ("mujoco", "RK4"),
          ("mujoco", "implicit"), ("pinocchio", "rkmk4"), ("pinocchio", "euler")]


def fake_run(n_variants: int):
    def row(variant, engine, integrator, stable_dt, unstable_dt):
        return MapRow(variant, engine, integrator, 1.0, "fixed", stable_dt, False, unstable_dt, "energy_growth",
                      float("nan"), "", False, None, stable_dt or float("nan"), [], {})

    names = [f"variant_number_{k}" for k in range(n_variants)]
    rows = [row(name, e, i, None if (k + j) % 5 == 0 else 1e-3 * (1 + j), 2e-3 * (1 + j))
            for k, name in enumerate(names) for j, (e, i) in enumerate(LABELS) if (k + j) % 7]
    return SimpleNamespace(variants=[SimpleNamespace(name=n) for n in names], skipped={}, rows=rows,
                           rates={n: 10.0 for n in names})


def _drawn(n_variants: int):
    fig = report.map_figure(fake_run(n_variants))
    fig.canvas.draw()
    return fig, fig.axes[0], fig.canvas.get_renderer()


def _overlap(a, b) -> bool:
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


@pytest.mark.parametrize("few,more", [(2, 4), (12, 20)])
def test_the_map_grows_with_the_variants_and_stays_small_for_few(few, more):
    (w1, h1), (w2, h2) = (_drawn(n)[0].get_size_inches() for n in (few, more))
    assert (w2 > w1 and h2 == h1) or (h2 > h1 and w2 == w1)  # one cell more per variant, along one side
    if few == 2:  # two variants: the engines down the rows, a figure a page holds
        assert w1 < 8 and h1 < 8


@pytest.mark.parametrize("n", [2, 12])
def test_the_map_legend_is_outside_the_axes_and_nothing_is_overprinted(n):
    fig, ax, renderer = _drawn(n)
    (legend,) = fig.legends
    box = legend.get_window_extent(renderer)
    assert not _overlap(box, ax.get_window_extent(renderer))
    assert not _overlap(box, ax.get_tightbbox(renderer))  # nor the tick labels
    for ticks in (ax.get_xticklabels(), ax.get_yticklabels()):
        boxes = [t.get_window_extent(renderer) for t in ticks]
        assert all(not _overlap(a, b) for i, a in enumerate(boxes) for b in boxes[i + 1:])
    sizes = [t.get_fontsize() for t in fig.findobj(lambda o: hasattr(o, "get_fontsize") and o.get_text() if
                                                   hasattr(o, "get_text") else False)]
    assert sizes and min(sizes) >= report.MIN_FONT


def test_the_map_png_takes_in_the_legend():
    png = report.map_png(fake_run(2))
    from io import BytesIO

    from PIL import Image

    width, height = Image.open(BytesIO(png)).size
    fig, _, renderer = _drawn(2)
    legend = fig.legends[0].get_window_extent(renderer).transformed(fig.dpi_scale_trans.inverted())  # inches
    tight = fig.get_tightbbox(renderer)
    assert tight.y0 <= legend.y0 + 1e-9 and tight.x1 >= legend.x1 - 1e-9  # the saved box holds the legend
    assert abs(height - round((tight.height + 0.3) * report.PLOT_DPI)) <= 2  # 0.15 in padding each side
    assert width < 900 and height < 900
