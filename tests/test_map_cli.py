"""`sweep map`: the map file as an independent reader sees it, and bad input at the edge."""
import subprocess
import sys

import h5py
import numpy as np
import pytest
import xarray as xr
from click.testing import CliRunner

from sweep.cli import main
from sweep.compute.maps import compute_map
from sweep.model import (END_STATE_MEANINGS, FINGER_MODE_MEANINGS, INFEASIBLE,
                         POINT_CLASS_MEANINGS, Design, Grid, Part)

REFERENCE = ["--l1", "2.0", "--l2", "1.6", "--r1", "0.2", "--r2", "0.14", "--w", "0.8",
             "--r", "0.4", "--mu", "0.4"]


@pytest.fixture(scope="module")
def map_file(tmp_path_factory):
    out = tmp_path_factory.mktemp("map") / "map.h5"
    result = CliRunner().invoke(main, ["map", *REFERENCE, "--h", "0.1", "--out", str(out)])
    assert result.exit_code == 0, result.output
    return out


def test_xarray_opens_the_map_with_labelled_dimensions(map_file):
    ds = xr.open_dataset(map_file, engine="h5netcdf")
    assert list(ds["finger"].values) == ["left", "right"]
    for name in ("energy", "point_class", "end_state", "equilibrium", "contained", "l_open",
                 "caging_score"):
        assert ds[name].dims == ("y", "x"), name
    for name in ("finger_mode", "theta1", "theta2", "k1", "k2", "tip_overlap"):
        assert ds[name].dims == ("finger", "y", "x"), name
    # coordinates are the MODEL 8 grid: x_i = i h (mirror-symmetric), y_j = r + j h
    h = ds.attrs["h"]
    assert np.allclose(ds.x.values, np.round(ds.x.values / h) * h, atol=1e-12)
    assert np.array_equal(ds.x.values, -ds.x.values[::-1])
    assert ds.y.values[0] == pytest.approx(0.4)
    # the caging area is Lambda h^2 less half the palm row's share (model-notes D36)
    assert 0.0 <= ds.attrs["Lambda"] * h ** 2 - ds.attrs["caging_area"] <= 0.5 * ds.x.size * h ** 2
    assert ds.attrs["sweep_version"]
    # the stored values are the computed ones
    m = compute_map(Design(2.0, 1.6, 0.2, 0.14, 0.8), Part(0.4, 0.4), grid=Grid(h=0.1))
    assert np.array_equal(ds["energy"].values, m.fields["energy"], equal_nan=True)
    assert ds.attrs["n_caged"] == m.attrs["n_caged"]


def test_categorical_variables_carry_cf_flags(map_file):
    with h5py.File(map_file) as f:
        for name, meanings in (("point_class", POINT_CLASS_MEANINGS),
                               ("end_state", END_STATE_MEANINGS),
                               ("finger_mode", FINGER_MODE_MEANINGS)):
            attrs = f[name].attrs
            assert list(attrs["flag_values"]) == list(range(len(meanings)))
            flag_meanings = attrs["flag_meanings"]
            if isinstance(flag_meanings, bytes):
                flag_meanings = flag_meanings.decode()
            assert flag_meanings.split() == list(meanings)
            assert set(np.unique(f[name][()])) <= set(range(-1, len(meanings)))
        assert [d.keys()[0] for d in f["theta1"].dims] == ["finger", "y", "x"]
        for key in ("Lambda", "caging_area", "n_caged", "n_tip_prehension", "n_ejection",
                    "n_stalled", "n_tip_overlap", "n_caged_crossed", "design", "part",
                    "command", "grid", "accuracy", "limits", "sweep_version"):
            assert key in f.attrs, key


def test_nan_only_where_infeasible(map_file):
    ds = xr.open_dataset(map_file, engine="h5netcdf", mask_and_scale=False)
    infeasible = ds["point_class"].values == INFEASIBLE
    for name in ("energy", "l_open", "caging_score"):
        assert not np.isnan(ds[name].values[~infeasible]).any(), name


def run_cli(args):
    return CliRunner().invoke(main, args)


@pytest.mark.parametrize("override, key", [
    (["--l1", "-1"], "l1"),
    (["--l2", "0"], "l2"),
    (["--mu", "-0.1"], "mu"),
    (["--h", "0"], "h"),
    (["--h", "-0.05"], "h"),
    (["--r", "nan"], "r"),
    (["--h", "1e-5"], "GiB"),           # a grid too large for memory
    (["--theta2-min", "5"], "theta2_min"),
    (["--xlim", "1", "-1"], "xlim"),
    (["--xlim", "-inf", "inf"], "xlim"),
    (["--h", "1e-300"], "too fine"),
    (["--ylim", "0", "1e300"], "too fine"),
    (["--reconfig-step", "1e-17"], "reconfig_step"),
    (["--root-tol", "0"], "root_tol"),
    (["--f-left", "0", "--f-right", "0"], "both 0"),
])
def test_bad_input_is_one_line_exit_2_and_writes_nothing(tmp_path, override, key):
    args = dict(zip(REFERENCE[::2], REFERENCE[1::2]))
    out = tmp_path / "out.h5"
    argv = ["map"]
    for name, value in args.items():
        if name not in override:
            argv += [name, value]
    argv += override + ["--out", str(out), "--plot", str(tmp_path / "p.png")]
    result = run_cli(argv)
    assert result.exit_code == 2, result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and key in lines[0], result.output
    assert list(tmp_path.iterdir()) == []


def test_equal_pulley_radii_are_supported(tmp_path):
    out = tmp_path / "eq.h5"
    argv = ["map", "--l1", "1.0", "--l2", "0.8", "--r1", "0.1", "--r2", "0.1", "--w", "0.4",
            "--r", "0.4", "--mu", "0.4", "--h", "0.2", "--out", str(out)]
    result = run_cli(argv)
    assert result.exit_code == 0, result.output
    ds = xr.open_dataset(out, engine="h5netcdf")
    assert ds.attrs["n_points"] == ds["energy"].size


def test_help_explains_the_command():
    result = run_cli(["map", "--help"])
    assert result.exit_code == 0
    for word in ("--l1", "--xlim", "--f-left", "--plot", "energy map"):
        assert word in result.output


def test_console_script_entry_point(tmp_path):
    result = subprocess.run([sys.executable, "-m", "sweep.cli", "--version"],
                            capture_output=True, text=True)
    assert result.returncode == 0 and "sweep" in result.stdout
