"""The picture benchmark's runner: fits side by side (--jobs), rows in the order of the
work, each fit the plan it gives alone."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from inkmotion.benchmarks.pictures import main


@pytest.mark.slow
def test_two_fits_at_once_give_the_rows_of_one_at_a_time(tmp_path: Path, capsys) -> None:
    args = ["text:hi", "text:io", "--scan", "clean-350-w2", "--steps", "30"]
    main([str(tmp_path / "one"), *args])
    main([str(tmp_path / "two"), *args, "--jobs", "2"])
    one, two = (json.loads((tmp_path / d / "pictures.json").read_text())
                for d in ("one", "two"))
    assert [r["source"] for r in two] == ["text:hi", "text:io"]  # the order of the work
    assert all("error" not in r for r in one + two), one + two
    timed = ("wall_s", "extraction_s", "fit_s", "job_s")
    assert ([{k: v for k, v in r.items() if k not in timed} for r in one]
            == [{k: v for k, v in r.items() if k not in timed} for r in two])
    for name in ("hi", "io"):  # the same plans, byte for byte
        plan = f"text-{name}--clean-350-w2/fit/plan.json"
        assert (tmp_path / "one" / plan).read_bytes() == (tmp_path / "two" / plan).read_bytes()


def test_no_fit_at_a_time_is_refused(tmp_path: Path) -> None:
    with pytest.raises(SystemExit):
        main([str(tmp_path), "text:hi", "--jobs", "0"])


@pytest.mark.slow
def test_a_picture_of_graffiti_is_drawn_without_an_arch_over_its_a(tmp_path: Path) -> None:
    """The clean 350-px picture of text:graffiti: the 'r' runs down, across and up a
    diagonal into the top of the a's bowl, one sub-movement from the 'r''s foot to the
    bowl's end. Started at the arc through that piece's peak (the default), the fit
    draws an arch over the whole chord and keeps it: 11.7 px from the recorded trace.
    Started halfway towards the arc closest to the piece (``--dce-bend-estimate
    between``), 7.5 px."""
    from inkmotion.benchmarks.pictures import SCANS, run_one

    (scan,) = [s for s in SCANS if s.name == "clean-350-w2"]
    row = run_one("text:graffiti", scan, tmp_path, None, ("--dce-bend-estimate", "between"))
    assert "error" not in row, row
    assert row["chamfer_max_px"] <= 8.0 and row["chamfer_mean_px"] <= 0.7, row
