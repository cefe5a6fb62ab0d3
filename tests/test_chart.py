"""The OpenCV line chart behind a fit's plots: ticks at round numbers, where lines land."""

import math
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from inkmotion.outputs.chart import MARGINS, Chart, nice_ticks, tick_label


@given(st.floats(min_value=1e-4, max_value=1e7, allow_nan=False))
def test_nice_ticks_are_round_and_cover_the_axis(top: float) -> None:
    ticks = nice_ticks(top)
    step = float(ticks[1] - ticks[0])
    mantissa = step / 10.0 ** math.floor(math.log10(step) + 1e-9)
    assert any(math.isclose(mantissa, m, rel_tol=1e-6) for m in (1.0, 2.0, 2.5, 5.0))
    assert ticks[0] == 0.0 and ticks[-1] <= top * (1 + 1e-9)
    assert ticks[-1] + step > top  # no room for another
    assert 3 <= len(ticks) <= 9, ticks


@pytest.mark.parametrize(("value", "text"), [(0.30000000000000004, "0.3"), (600.0, "600"),
                                             (2.5, "2.5"), (0.125, "0.125"), (0.0, "0")])
def test_tick_labels_drop_round_off(value: float, text: str) -> None:
    assert tick_label(value) == text


def test_a_line_lands_where_its_data_says(tmp_path: Path) -> None:
    """A horizontal line at y = 0.5 of a [0, 1] axis is drawn half-way up the box, a vertical
    rule at x = 0.25 a quarter of the way across; a labelled line gets a legend."""
    size = (600, 300)
    chart = Chart(size, 1.0, 1.0, title="t", x_label="x", y_label="y")
    chart.lines([(np.array([0.0, 1.0]), np.array([0.5, 0.5]))], (200, 0, 0), label="red")
    chart.rule(0.25, (0, 0, 200))
    chart.write(tmp_path / "c.png")
    img = cv2.imread(str(tmp_path / "c.png"), cv2.IMREAD_COLOR).astype(int)
    left, top, right, bottom = MARGINS
    red = (img[..., 2] - img[..., 0] > 100) & (img[..., 2] > 150)
    rows = np.flatnonzero(red[top:, left + 20:left + 60].any(axis=1)) + top  # in the box
    assert abs(rows.mean() - (top + (size[1] - bottom)) / 2) <= 1.0, rows
    blue = img[..., 0] - img[..., 2] > 60  # a thin rule: half a pixel's ink
    cols = np.flatnonzero(blue[top + 10:size[1] - bottom - 10].any(axis=0))
    assert abs(cols.mean() - (left + 0.25 * (size[0] - right - left))) <= 1.0, cols
    legend = red[:top, size[0] - right - 160:size[0] - right]
    assert legend.any()  # the legend's sample of the line, above the box on the right


def test_a_chart_without_room_refuses() -> None:
    with pytest.raises(AssertionError):
        Chart((300, 200), 0.0, 1.0)


def test_a_gap_in_the_data_breaks_the_line(tmp_path: Path) -> None:
    """NaN and infinite values break a line into the runs around them (as matplotlib
    draws them), never a stroke to a wild pixel."""
    size = (600, 300)
    chart = Chart(size, 1.0, 1.0)
    x = np.linspace(0.0, 1.0, 11)
    y = np.full(11, 0.5)
    y[5], y[8] = np.nan, np.inf
    chart.lines([(x, y)], (200, 0, 0))
    chart.write(tmp_path / "c.png")
    img = cv2.imread(str(tmp_path / "c.png"), cv2.IMREAD_COLOR).astype(int)
    left, top, right, bottom = MARGINS
    red = ((img[..., 2] - img[..., 0] > 100) & (img[..., 2] > 150)).any(axis=0)
    column = [round(left + v * (size[0] - right - left)) for v in x]
    assert red[column[2]] and red[column[6] + 5] and red[column[9] + 5]
    assert not red[column[5]] and not red[column[8]]  # the gaps
    rows = np.flatnonzero(((img[..., 2] - img[..., 0] > 100) & (img[..., 2] > 150)).any(axis=1))
    assert rows.max() - rows.min() <= 3  # nothing drawn towards the infinity
