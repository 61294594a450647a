"""The map picture: a valid PNG written atomically, nothing left behind on failure."""
from __future__ import annotations

import numpy as np
import pytest

from sweep.compute.maps import compute_map
from sweep.model import (END_CAGED, END_EJECTION, END_STALLED, END_TIP_PREHENSION, REACHED,
                         Accuracy, Command, Design, Grid, Part)
from sweep.report.plot import _title, plot_map, sliding_points

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def small_map():
    return compute_map(Design(2.0, 1.6, 0.2, 0.14, 0.8), Part(0.4, 0.4), Command(1.0, 1.0),
                       Grid(h=0.2))


def test_plot_writes_a_png_atomically(small_map, tmp_path):
    out = tmp_path / "sub" / "map.png"
    written = plot_map(small_map, out)
    assert written == out
    data = out.read_bytes()
    assert len(data) > 1000
    assert data[:8] == PNG_MAGIC
    assert sorted(p.name for p in out.parent.iterdir()) == ["map.png"]  # no temp file left


def test_plot_file_has_the_usual_permissions(small_map, tmp_path):
    out = plot_map(small_map, tmp_path / "map.png")
    other = tmp_path / "other"
    other.write_bytes(b"")
    assert out.stat().st_mode & 0o777 == other.stat().st_mode & 0o777


def test_plot_overwrites_an_existing_file(small_map, tmp_path):
    out = tmp_path / "map.png"
    out.write_bytes(b"old")
    plot_map(small_map, str(out))
    assert out.read_bytes()[:8] == PNG_MAGIC
    assert [p.name for p in tmp_path.iterdir()] == ["map.png"]


def test_plot_fails_cleanly_when_the_directory_cannot_be_made(small_map, tmp_path):
    blocker = tmp_path / "not_a_dir"
    blocker.write_text("a file where a directory is needed")
    with pytest.raises(OSError):
        plot_map(small_map, blocker / "sub" / "map.png")
    assert [p.name for p in tmp_path.iterdir()] == ["not_a_dir"]
    assert blocker.read_text() == "a file where a directory is needed"


def test_plot_leaves_no_temp_file_when_saving_fails(small_map, tmp_path, monkeypatch):
    from matplotlib.figure import Figure

    def broken_savefig(self, *args, **kwargs):
        raise RuntimeError("disk full")

    monkeypatch.setattr(Figure, "savefig", broken_savefig)
    out = tmp_path / "map.png"
    out.write_bytes(b"previous picture")
    with pytest.raises(RuntimeError):
        plot_map(small_map, out)
    assert [p.name for p in tmp_path.iterdir()] == ["map.png"]
    assert out.read_bytes() == b"previous picture"  # the old file is untouched


def test_plotted_trajectory_ends_match_the_kernel(small_map):
    """The picture's paths (walked with the kernels' own step, `successor`, step checks
    included) end where the kernel says: at the point `end_index` names, with the end state
    `end_state` says (grid8)."""
    grid8 = compute_map(Design(2.0, 1.6, 0.2, 0.14, 0.8), Part(0.4, 0.4), Command(1.0, 1.0),
                        Grid(h=0.2), accuracy=Accuracy(trajectory="grid8"))
    f = grid8.fields
    reached = f["point_class"] == REACHED
    stable = reached & f["equilibrium"]
    nx = f["energy"].shape[1]
    starts = np.flatnonzero(reached.ravel())
    assert starts.size > 50
    for p in starts:
        end = sliding_points(int(p), grid8, stable, sliding=False)[1]
        assert end == f["end_index"].ravel()[p]
        j, i = divmod(end, nx)
        state = f["end_state"].ravel()[p]
        if stable[j, i]:
            assert state == (END_CAGED if f["end_state"][j, i] == END_CAGED
                             else END_TIP_PREHENSION)
        elif not reached[j, i]:
            assert state == END_EJECTION
        else:   # stalled there, or a checked step left P_j next to it (model-notes D36)
            assert state in (END_STALLED, END_EJECTION)


def test_plotted_sliding_paths_end_where_the_kernel_says():
    """A sliding map (the default): the picture's paths, slides included, end at the point
    `end_index` names, and a stalled path's last position is within half a grid step of it."""
    m = compute_map(Design(2.0, 1.6, 0.16, 0.06, 1.2), Part(0.4, 0.1), Command(1.0, 1.0),
                    Grid(h=0.05, xlim=(-2.6, -1.0), ylim=(0.4, 2.2)))
    f = m.fields
    reached = f["point_class"] == REACHED
    stable = reached & f["equilibrium"]
    starts = np.flatnonzero(reached.ravel())
    slid = 0
    for p in starts[::5]:
        pts, end = sliding_points(int(p), m, stable)
        assert end == f["end_index"].ravel()[p]
        j, i = divmod(end, m.x.size)
        if f["end_state"].ravel()[p] == END_STALLED:
            assert abs(pts[-1, 0] - m.x[i]) <= 0.5 * 0.05 + 1e-9
            assert abs(pts[-1, 1] - m.y[j]) <= 0.5 * 0.05 + 1e-9
        on_grid = np.isclose(pts[:, 0] / 0.05, np.round(pts[:, 0] / 0.05)) & \
            np.isclose((pts[:, 1] - 0.4) / 0.05, np.round((pts[:, 1] - 0.4) / 0.05))
        slid += int(not on_grid.all())
    assert slid > 0  # some drawn paths contain a slide off the grid


def test_title_says_when_the_map_is_a_user_window():
    windowed = compute_map(Design(2.0, 1.6, 0.2, 0.14, 0.8), Part(0.4, 0.4), Command(),
                           Grid(h=0.2, xlim=(-1.0, 1.0), ylim=(0.4, 2.0)))
    whole = compute_map(Design(2.0, 1.6, 0.2, 0.14, 0.8), Part(0.4, 0.4), Command(), Grid(h=0.2))
    assert "user window" in _title(windowed)[1]
    assert "user window" not in _title(whole)[1]
