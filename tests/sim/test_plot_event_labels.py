"""Event labels sit in a strip above the upper axes: none hides a trace, none overlaps another."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from ctrlblocks.sim.plot import _label_events, label_rows


def test_labels_that_do_not_touch_share_the_first_row():
    assert label_rows([0.0, 0.3, 0.6], [0.2, 0.2, 0.2]) == [0, 0, 0]


def test_a_label_that_would_run_into_its_neighbour_goes_one_row_up():
    # 0.1 + 0.25 ends after 0.3 starts: row 1; the third fits after the first again.
    assert label_rows([0.1, 0.3, 0.4], [0.25, 0.05, 0.1]) == [0, 1, 0]


def test_rows_do_not_depend_on_the_order_the_labels_come_in():
    x0, w = [0.4, 0.1, 0.3], [0.1, 0.25, 0.05]
    assert label_rows(x0, w) == [0, 0, 1]


def test_a_pile_of_labels_uses_one_row_each():
    assert sorted(label_rows([0.5] * 4, [0.1] * 4)) == [0, 1, 2, 3]


@pytest.mark.timeout(60)
def test_drawn_labels_lie_above_the_axes_and_do_not_overlap(tmp_path):
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 3.4))
    ax.plot([0, 100], [0, 1])
    ax.set_xlim(0, 100)
    events = [SimpleNamespace(t=t, label=lab) for t, lab in [
        (0.0, "initial"), (10.0, "load +0.5 bar"), (12.0, "valve b opens"),
        (14.0, "SP 1.5; AUTO"), (60.0, "load removed"), (60.0, "MAN"),
    ]]  # fmt: skip
    rows = _label_events(ax, events)
    assert rows == 3  # three labels within 4 % of the width pile up
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    texts = [c for c in ax.texts]
    assert sorted(t.get_text() for t in texts) == [
        "SP 1.5; AUTO", "load +0.5 bar", "load removed; MAN", "valve b opens"
    ]  # fmt: skip
    boxes = [t.get_window_extent(renderer) for t in texts]
    top = ax.get_window_extent(renderer).y1
    assert all(b.y0 >= top for b in boxes)
    for i, a in enumerate(boxes):
        for b in boxes[i + 1 :]:
            assert not a.overlaps(b), (a, b)
    plt.close(fig)
